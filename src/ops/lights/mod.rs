//! Lights: analytic lights taken out of (or put into) environment maps.

pub mod extract_lights;
pub mod sun_extract;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(sun_extract::spec());
    r.register(extract_lights::spec());
}
