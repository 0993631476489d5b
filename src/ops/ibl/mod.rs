//! Image-based lighting: cube maps and equal-area octahedral maps from lat-long ones and back
//! (energy-preserving), the specular prefiltered chain, diffuse irradiance and the split-sum BRDF
//! texture. Conventions: `geometry::cubemap` (face order and axes), `geometry::octahedral`
//! (pbrt-v4's mapping and axes), `maths::ggx` (roughness, lobe, DFG), `maths::irradiance_cube`.

pub mod brdf_lut;
pub mod cubemap_to_latlong;
pub mod irradiance_cubemap;
pub mod latlong_to_cubemap;
pub mod latlong_to_octahedral;
pub mod octahedral_to_latlong;
pub mod prefilter_specular;

use crate::data::{Cubemap, Image};
use crate::engine::op::{OpContext, OpError};
use crate::engine::registry::Registry;
use crate::maths::resample::{to_cube, CubeSource, LatLongSource};

crate::params! {
    /// The output size of the operators that make a lat-long map (`CubemapToLatLong`,
    /// `OctahedralToLatLong`).
    pub struct LatLongSizeParams {
        /// width in texels
        #[range(1, 65536)]
        pub width: usize,
        /// height in texels
        #[range(1, 65536)]
        pub height: usize,
    }
}

pub fn register(r: &mut Registry) {
    r.register(latlong_to_cubemap::spec());
    r.register(cubemap_to_latlong::spec());
    r.register(latlong_to_octahedral::spec());
    r.register(octahedral_to_latlong::spec());
    r.register(prefilter_specular::spec());
    r.register(irradiance_cubemap::spec());
    r.register(brdf_lut::spec());
}

/// An error naming the first non-finite value of a cube map.
pub(crate) fn check_cube_finite(c: &Cubemap) -> Result<(), OpError> {
    match c.data.iter().position(|v| !v.is_finite()) {
        Some(i) => {
            let t = i / 3;
            let s = c.size;
            Err(OpError::Invalid(format!(
                "texel ({}, {}) of face {} of the cube map is {}: filtering needs finite radiance",
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
/// that size as it is, anything else resampled (energy-preserving). Non-finite texels are an
/// error.
pub(crate) fn env_cube(ctx: &OpContext, size: usize) -> Result<Cubemap, OpError> {
    if let Some(c) = ctx.input("env").get::<Cubemap>() {
        check_cube_finite(c)?;
        return Ok(if c.size == size { c.clone() } else { to_cube(&CubeSource::new(c), size) });
    }
    let img: &Image = ctx.get("env");
    crate::ops::shading::reference_sphere::check_finite(img)?;
    Ok(to_cube(&LatLongSource::new(img), size))
}
