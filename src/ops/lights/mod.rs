//! Lights: analytic lights taken out of (or put into) environment maps, and spherical
//! Gaussian fits of them.

pub mod extract_lights;
pub mod sg_to_latlong;
pub mod spherical_gaussians;
pub mod sun_extract;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(sun_extract::spec())?;
    r.register(extract_lights::spec())?;
    r.register(spherical_gaussians::spec())?;
    r.register(sg_to_latlong::spec())?;
    Ok(())
}
