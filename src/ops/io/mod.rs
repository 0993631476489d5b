//! Reading and writing files.

pub mod load_hdr;
pub mod save;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(load_hdr::spec())?;
    r.register(save::spec())?;
    Ok(())
}
