//! Capture: from bracketed photographs to a calibrated HDR map. Loading camera images and
//! bracket sequences (with their EXIF exposure times), aligning the frames, recovering the
//! camera's response, merging the exposures into relative radiance, exposure fusion for a
//! preview, calibrating a map to a measured illuminance, and joining two mirror-ball views.
//! The maths they share is `crate::maths::capture`.

pub mod align_brackets;
pub mod calibrate_illuminance;
pub mod merge_mirror_balls;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(align_brackets::spec())?;
    r.register(calibrate_illuminance::spec())?;
    r.register(merge_mirror_balls::spec())?;
    Ok(())
}
