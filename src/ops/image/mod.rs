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
    r.register(luminance::spec());
    r.register(flip_vertical::spec());
    r.register(resize::spec());
    r.register(exposure::spec());
    r.register(constant::spec());
    r.register(angular_to_latlong::spec());
    r.register(overlay::spec());
    r.register(image_error::spec());
}
