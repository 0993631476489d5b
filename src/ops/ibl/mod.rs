//! Image-based lighting: cube maps and equal-area octahedral maps from lat-long ones and back
//! (energy-preserving), cube maps to and from one image of a layout (crosses, dice, strips) and
//! six face images (exact copies), the specular prefiltered chain, diffuse irradiance and the
//! split-sum BRDF texture. Conventions: `geometry::cubemap` (face order and axes),
//! `geometry::cube_layout` (layouts), `geometry::octahedral` (pbrt-v4's mapping and axes),
//! `maths::brdf::ggx` (roughness, lobe, DFG), `maths::ibl::irradiance_cube`.

pub mod brdf_lut;
pub mod cubemap_face;
pub mod cubemap_to_latlong;
pub mod cubemap_to_layout;
pub mod faces_to_cubemap;
pub mod irradiance_cubemap;
pub mod latlong_to_cubemap;
pub mod latlong_to_octahedral;
pub mod layout_to_cubemap;
pub mod octahedral_to_latlong;
pub mod playcanvas_env_atlas;
pub mod prefilter_specular;

use crate::engine::fields::{AnyValue, Input};
use crate::engine::op::{OpContext, OpError};
use crate::engine::registry::{Registry, RegistryError};
use crate::maths::resample::latlong_cube::latlong_to_cube;
use crate::maths::resample::layouts::{downsample, to_cube, CubeSource, LatLongSource};
use crate::ops::latlong_input::warn_unless_latlong_size;
use crate::values::{Cubemap, Image};

/// Declares the parameters of an operator that makes a lat-long map (`CubemapToLatLong`,
/// `OctahedralToLatLong`): the operator's input fields (given in the braces, first, so that
/// `hdrflow ops` lists them first), then the output size `width` and `height`.
macro_rules! latlong_size_params {
    ($name:ident { $($inputs:tt)* }) => {
        crate::params! {
            /// The inputs and output size of an operator that makes a lat-long map.
            pub struct $name {
                $($inputs)*
                /// width in texels
                #[range(1, 65536)]
                pub width: usize,
                /// height in texels
                #[range(1, 65536)]
                pub height: usize,
            }
        }
    };
}
pub(crate) use latlong_size_params;

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(latlong_to_cubemap::spec())?;
    r.register(cubemap_to_latlong::spec())?;
    r.register(cubemap_to_layout::spec())?;
    r.register(layout_to_cubemap::spec())?;
    r.register(cubemap_face::spec())?;
    r.register(faces_to_cubemap::spec())?;
    r.register(latlong_to_octahedral::spec())?;
    r.register(octahedral_to_latlong::spec())?;
    r.register(prefilter_specular::spec())?;
    r.register(irradiance_cubemap::spec())?;
    r.register(brdf_lut::spec())?;
    r.register(playcanvas_env_atlas::spec())?;
    Ok(())
}

/// An error naming the first non-finite value of a cube map.
pub(crate) fn check_cube_finite(c: &Cubemap) -> Result<(), OpError> {
    match c.data.iter().position(|v| !v.is_finite()) {
        Some(i) => {
            let t = i / 3;
            let s = c.size;
            Err(OpError::Invalid(format!(
                "texel ({}, {}) of face {} of the cube map is {}: cube maps must hold finite radiance",
                t % s,
                (t / s) % s,
                crate::geometry::cubemap::FACE_NAMES[t / (s * s)],
                c.data[i]
            )))
        }
        None => Ok(()),
    }
}

/// The `env` input (a lat-long image or a cube map) as a cube map of face size `size`: a cube of
/// that size as it is, a cube 2^k times larger halved k times (each texel the exact
/// solid-angle-weighted mean of its children: the same footprint means as a resampling, at the
/// cost of one pass), anything else resampled (energy-preserving). Non-finite texels are an
/// error.
pub(crate) fn env_cube(ctx: &mut OpContext, env: &Input<AnyValue>, size: usize) -> Result<Cubemap, OpError> {
    if let Some(c) = env.value().get::<Cubemap>() {
        check_cube_finite(c)?;
        let halvings =
            (c.size % size == 0 && (c.size / size).is_power_of_two()).then(|| (c.size / size).trailing_zeros());
        return Ok(match halvings {
            Some(0) => c.clone(),
            Some(k) => (1..k).fold(downsample(c), |half, _| downsample(&half)),
            None => to_cube(&CubeSource::new(c), size),
        });
    }
    let img = env_image(ctx, env)?;
    crate::ops::latlong_input::check_finite(img)?;
    Ok(latlong_to_cube(&LatLongSource::new(img), size))
}

/// The `env` input as a lat-long image, when it is not a cube map (validation accepts only these
/// two types, so anything else is a bug in a declaration); warns when it is not 2:1.
pub(crate) fn env_image<'v>(ctx: &mut OpContext, env: &'v Input<AnyValue>) -> Result<&'v Image, OpError> {
    let img = env.value().get::<Image>().ok_or_else(|| {
        OpError::Invalid(format!(
            "input {:?} is a {}, neither a lat-long image nor a cube map (a bug in its declaration)",
            env.field(),
            env.value_type()
        ))
    })?;
    warn_unless_latlong_size(ctx, env.field(), img.width, img.height);
    Ok(img)
}
