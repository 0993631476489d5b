//! Capture: from bracketed photographs to a calibrated HDR map. Loading camera images and
//! bracket sequences (with their EXIF exposure times), aligning the frames, recovering the
//! camera's response, merging the exposures into relative radiance, exposure fusion for a
//! preview, calibrating a map to a measured illuminance, and joining two mirror-ball views.
//! The maths they share is `crate::maths::capture`.

pub mod align_brackets;
pub mod bracket_files;
pub mod calibrate_illuminance;
pub mod calibrate_response;
pub mod fuse_exposures;
pub mod load_brackets;
pub mod load_image;
pub mod merge_brackets;
pub mod merge_mirror_balls;
pub mod simulate_brackets;

use crate::engine::op::OpError;
use crate::engine::registry::{Registry, RegistryError};
use crate::values::brackets::Brackets;

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(load_image::spec())?;
    r.register(load_brackets::spec())?;
    r.register(simulate_brackets::spec())?;
    r.register(calibrate_response::spec())?;
    r.register(merge_brackets::spec())?;
    r.register(fuse_exposures::spec())?;
    r.register(align_brackets::spec())?;
    r.register(calibrate_illuminance::spec())?;
    r.register(merge_mirror_balls::spec())?;
    Ok(())
}

/// A run error unless `b` has at least `n` frames, all of its size (the type guarantees it;
/// checked again so that a bracket built by hand fails cleanly), naming the frame.
pub fn require_frames(b: &Brackets, n: usize) -> Result<(), OpError> {
    if b.frames.len() < n {
        return Err(OpError::Invalid(format!(
            "the bracket has {} frame{}: at least {n} exposures are needed",
            b.frames.len(),
            if b.frames.len() == 1 { "" } else { "s" }
        )));
    }
    for f in &b.frames {
        if f.codes.len() != b.pixel_count() * 3 || f.codes.bits() != b.bit_depth {
            return Err(OpError::Invalid(format!(
                "frame {} is not {} x {} x 3 codes of {} bits",
                f.name, b.width, b.height, b.bit_depth
            )));
        }
        if f.covered.as_ref().is_some_and(|m| m.len() != b.pixel_count()) {
            return Err(OpError::Invalid(format!(
                "frame {}'s coverage mask is not {} x {}",
                f.name, b.width, b.height
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::brackets::{Codes, Frame};

    fn frame(name: &str, time: f64, n: usize) -> Frame {
        Frame { name: name.into(), time, codes: Codes::U8(vec![9; n]), covered: None }
    }

    #[test]
    fn one_frame_and_a_frame_of_another_size_are_run_errors_naming_it() {
        let one = Brackets::new(2, 1, 8, vec![frame("a.jpg", 1.0, 6)]).unwrap();
        let e = require_frames(&one, 2).unwrap_err().to_string();
        assert!(e.contains("the bracket has 1 frame: at least 2 exposures are needed"), "{e}");
        // Built by hand past `Brackets::new`'s checks: still an error, not a panic.
        let mut odd = Brackets::new(2, 1, 8, vec![frame("a.jpg", 1.0, 6), frame("b.jpg", 2.0, 6)]).unwrap();
        odd.frames[1].codes = Codes::U8(vec![0; 5]);
        let e = require_frames(&odd, 2).unwrap_err().to_string();
        assert!(e.contains("frame b.jpg is not 2 x 1 x 3 codes of 8 bits"), "{e}");
    }
}
