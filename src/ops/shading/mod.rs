//! Shading: relighting objects with an environment.
//!
//! Every sphere renderer takes the same `size`, `albedo` and `view` fields (declared in each
//! operator's parameter struct with the same ranges and defaults), so that their images compare
//! pixel for pixel.

pub mod glossy_sphere;
pub mod per_pixel_sphere;
pub mod reference_glossy_sphere;
pub mod reference_sphere;
pub mod relight_sphere;
pub mod sh_irradiance;
pub mod sh_sphere;

use crate::engine::fields::Shape;
use crate::engine::op::CheckProblem;
use crate::engine::registry::{Registry, RegistryError};
use crate::geometry::latlong;
use crate::maths::render::relight::SphereView;

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(relight_sphere::spec())?;
    r.register(reference_sphere::spec())?;
    r.register(sh_irradiance::spec())?;
    r.register(sh_sphere::spec())?;
    r.register(per_pixel_sphere::spec())?;
    r.register(glossy_sphere::spec())?;
    r.register(reference_glossy_sphere::spec())?;
    Ok(())
}

/// Declares a sphere renderer's parameters: the operator's inputs (first, so that they are listed
/// first), then the `size`, `albedo` and `view` every sphere operator shares (so that their images
/// compare pixel for pixel), then the operator's own fields, as one `params!` struct:
/// `sphere_params! { MyParams { /// doc
/// #[input(&[IMAGE_T])] pub env: Input<Image> } { /// doc
/// pub spp: usize = 16, } }`.
macro_rules! sphere_params {
    (
        $name:ident { $( $(#[$($iattr:tt)*])* $ivis:vis $input:ident : $ity:ty ),* $(,)? }
        { $($rest:tt)* }
    ) => {
        crate::params! {
            pub struct $name {
                $( $(#[$($iattr)*])* $ivis $input: $ity, )*
                /// image width and height
                #[range(1, 1 << 14)]
                pub size: usize = 256,
                /// diffuse albedo (RGB, or a single number for grey)
                #[range(0.0, 1.0)]
                pub albedo: Rgb = Rgb([1.0, 1.0, 1.0]),
                /// camera direction (theta, phi) in degrees, lat-long convention; the seed's is (90, 90)
                #[range(-360.0, 360.0)]
                pub view: [f64; 2] = [90.0, 90.0],
                $($rest)*
            }
        }
    };
}
pub(crate) use sphere_params;

/// Declares a glossy sphere renderer's parameters: the operator's inputs, then the modified
/// Phong BRDF's `exponent`, `diffuse` and `specular`, `size` and `view` as in
/// [`sphere_params!`], then the operator's own fields (`GlossySphere` and
/// `ReferenceGlossySphere` share them, so their images compare pixel for pixel):
/// `glossy_params! { MyParams { inputs } { own fields } }`.
macro_rules! glossy_params {
    (
        $name:ident { $( $(#[$($iattr:tt)*])* $ivis:vis $input:ident : $ity:ty ),* $(,)? }
        { $($rest:tt)* }
    ) => {
        crate::params! {
            pub struct $name {
                $( $(#[$($iattr)*])* $ivis $input: $ity, )*
                /// Phong exponent s of the specular lobe (cos^s of the angle to the mirror direction)
                #[range(0.0, 1e6)]
                pub exponent: f64 = 10.0,
                /// diffuse reflectance k_d (RGB, or a single number for grey): f = k_d / pi + ...
                #[range(0.0, 1.0)]
                pub diffuse: Rgb = Rgb([0.2, 0.2, 0.2]),
                /// specular reflectance k_s: ... + k_s (s + 2) / (2 pi) cos^s(alpha)
                #[range(0.0, 1.0)]
                pub specular: Rgb = Rgb([0.8, 0.8, 0.8]),
                /// image width and height
                #[range(1, 1 << 14)]
                pub size: usize = 256,
                /// camera direction (theta, phi) in degrees, lat-long convention; the seed's is (90, 90)
                #[range(-360.0, 360.0)]
                pub view: [f64; 2] = [90.0, 90.0],
                $($rest)*
            }
        }
    };
}
pub(crate) use glossy_params;

/// The sphere seen from `view` = (theta, phi) in degrees, inscribed in a `size` x `size` image.
pub(crate) fn sphere_view(size: usize, view: [f64; 2]) -> SphereView {
    SphereView::new(size, latlong::direction_deg(view[0], view[1]))
}

/// Refuses a `cdf` of another size than `env` when both sizes are known before running.
pub(crate) fn check_env_cdf_sizes(env: Shape, cdf: Shape) -> Result<(), CheckProblem> {
    crate::engine::op::check_same_size(env, cdf)
}
