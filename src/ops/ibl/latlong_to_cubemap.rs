//! `LatLongToCubemap(image, size)`: a lat-long map as a cube map of face size `size`, faces
//! +X, -X, +Y, -Y, +Z, -Z in hdrflow's axes (`geometry::cubemap`).
//!
//! Energy-preserving: each cube texel is the solid-angle-weighted average of the lat-long map
//! (read as piecewise constant) over the texel's footprint, by adaptive subdivision with exact
//! cell solid angles (`maths::resample`). A constant map gives the same constant to rounding; the
//! sphere integral is kept to 1e-3 relative on the built-in sky (2-degree sun), and texels on
//! both sides of a face edge agree as neighbours inside a face do (tests).

use crate::engine::fields::{Check, Input};
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::Value;
use crate::maths::resample::{to_cube, LatLongSource};
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct LatLongToCubemapParams {
        /// the lat-long map (RGB; one channel is read as grey)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// face size in texels (the cube has 6 size^2 texels)
        #[range(1, 16384)]
        pub size: usize,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new(
        "LatLongToCubemap",
        "ibl",
        1,
        "Lat-long map to cube map (+X -X +Y -Y +Z -Z), each texel the solid-angle-weighted mean of its footprint",
    )
    .output("cubemap", OutputType::Fixed(CUBEMAP_T), "the cube map")
    .size(|_, p: LatLongToCubemapParams<Check>| Some((6 * p.size as u64, p.size as u64)))
    .code_hash(crate::op_code_hash!())
    .eval(eval)
}

fn eval(ctx: &mut OpContext, p: LatLongToCubemapParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, "image", p.image.width, p.image.height);
    let img = &*p.image;
    crate::ops::shading::reference_sphere::check_finite(img)?;
    Ok(Value::new(to_cube(&LatLongSource::new(img), p.size)))
}
