//! Sampling: importance-sampling distributions and the samplers that draw from them.

pub mod build_cdf;
pub mod phong_sample;
pub mod sample;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(build_cdf::spec())?;
    r.register(sample::spec())?;
    r.register(phong_sample::spec())?;
    Ok(())
}
