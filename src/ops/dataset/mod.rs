//! Dataset preparation: what a lighting-estimation dataset stores beside each crop.

pub mod crop_label;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(crop_label::spec())?;
    Ok(())
}
