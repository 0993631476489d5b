//! Capture: from bracketed photographs to a calibrated HDR map. Loading camera images and
//! bracket sequences (with their EXIF exposure times), aligning the frames, recovering the
//! camera's response, merging the exposures into relative radiance, exposure fusion for a
//! preview, calibrating a map to a measured illuminance, and joining two mirror-ball views.
//! The maths they share is `crate::maths::capture`.

pub mod bracket_files;
pub mod load_brackets;
pub mod load_image;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    let _ = r;
    r.register(load_image::spec())?;
    r.register(load_brackets::spec())?;
    Ok(())
}
