//! Shading: relighting objects with an environment.

pub mod per_pixel_sphere;
pub mod reference_sphere;
pub mod relight_sphere;
pub mod sh_irradiance;
pub mod sh_sphere;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(&relight_sphere::SPEC);
    r.register(&reference_sphere::SPEC);
    r.register(&sh_irradiance::SPEC);
    r.register(&sh_sphere::SPEC);
    r.register(&per_pixel_sphere::SPEC);
}
