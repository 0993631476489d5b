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

use crate::engine::op::{Default, FieldKind, FieldSpec};

/// The fields every sphere renderer shares, so that their images compare pixel for pixel.
pub(crate) const SIZE_FIELD: FieldSpec = FieldSpec {
    name: "size",
    kind: FieldKind::Int { min: 1, max: 1 << 14 },
    default: Default::Int(256),
    doc: "image width and height",
};
pub(crate) const ALBEDO_FIELD: FieldSpec = FieldSpec {
    name: "albedo",
    kind: FieldKind::Tuple { len: 3, min: 0.0, max: 1.0 },
    default: Default::Tuple(&[1.0, 1.0, 1.0]),
    doc: "diffuse albedo (RGB)",
};
pub(crate) const VIEW_FIELD: FieldSpec = FieldSpec {
    name: "view",
    kind: FieldKind::Tuple { len: 2, min: -360.0, max: 360.0 },
    default: Default::Tuple(&[90.0, 90.0]),
    doc: "camera direction (theta, phi) in degrees, lat-long convention; the seed's is (90, 90)",
};
