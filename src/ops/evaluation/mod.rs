//! Evaluation: what a lighting-estimation paper reports about a predicted map against its
//! ground truth, as the published protocol computes it (StyleLight, EMLight, DiffusionLight:
//! `DiffusionLight/DiffusionLight-evaluation`), and the protocol's probe spheres computed without
//! Blender.

pub mod image_metrics;
pub mod lights_error;
pub mod probe_sphere;
pub mod protocol_tonemap;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(image_metrics::spec())?;
    r.register(lights_error::spec())?;
    r.register(protocol_tonemap::spec())?;
    r.register(probe_sphere::spec())?;
    Ok(())
}
