//! Shading: relighting objects with an environment.
//!
//! Every sphere renderer takes the same `size`, `albedo` and `view` fields (declared in each
//! operator's parameter struct with the same ranges and defaults), so that their images compare
//! pixel for pixel.

pub mod per_pixel_sphere;
pub mod reference_sphere;
pub mod relight_sphere;
pub mod sh_irradiance;
pub mod sh_sphere;

use crate::engine::params::Choice;
use crate::engine::registry::Registry;
use crate::geometry::latlong;
use crate::maths::per_pixel::PerPixelStrategy;
use crate::maths::relight::SphereView;

pub fn register(r: &mut Registry) {
    r.register(relight_sphere::spec());
    r.register(reference_sphere::spec());
    r.register(sh_irradiance::spec());
    r.register(sh_sphere::spec());
    r.register(per_pixel_sphere::spec());
}

/// The sphere seen from `view` = (theta, phi) in degrees, inscribed in a `size` x `size` image.
pub(crate) fn sphere_view(size: usize, view: [f64; 2]) -> SphereView {
    SphereView::new(size, latlong::direction_deg(view[0], view[1]))
}

impl Choice for PerPixelStrategy {
    const NAMES: &'static [&'static str] = PerPixelStrategy::NAMES;
    fn from_name(name: &str) -> Option<Self> {
        PerPixelStrategy::from_name(name)
    }
    fn name(self) -> &'static str {
        PerPixelStrategy::name(self)
    }
}
crate::choice_param!(PerPixelStrategy);
