//! Curves and plots.

pub mod fresnel;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(fresnel::spec())?;
    Ok(())
}
