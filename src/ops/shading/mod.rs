//! Shading: relighting objects with an environment.

pub mod relight_sphere;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(&relight_sphere::SPEC);
}
