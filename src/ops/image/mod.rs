//! Per-image operations.

pub mod angular_to_latlong;
pub mod constant;
pub mod exposure;
pub mod flip_vertical;
pub mod image_error;
pub mod luminance;
pub mod overlay;
pub mod resize;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(&luminance::SPEC);
    r.register(&flip_vertical::SPEC);
    r.register(&resize::SPEC);
    r.register(&exposure::SPEC);
    r.register(&constant::SPEC);
    r.register(&angular_to_latlong::SPEC);
    r.register(&overlay::SPEC);
    r.register(&image_error::SPEC);
}
