//! `ReferenceSphere(env, size: 256, albedo, view)`: the exact answer for the relit diffuse
//! sphere, `Lo(n) = (albedo / pi) sum_texels L dOmega max(n.d, 0)` at every pixel of the disc
//! (`maths::render::reference`), 0 elsewhere. Same `size`, `albedo` and `view` fields and defaults as
//! `RelightSphere`, so the images compare pixel for pixel (e.g. with `ImageError`): the
//! expectation of `RelightSphere` with `Unbiased` samples from `Sample` is exactly this image
//! (up to f32 rounding).
//!
//! Cost: O(pixels x lit texels), a brute-force sum made fast by culling and SIMD (timings in
//! docs/src/benchmarks/point-targets.md).

use super::sphere_view;
use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::render::reference::reference_sphere;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;

super::sphere_params! {
    ReferenceParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
    } {}
}

pub fn spec() -> OpSpec {
    Op::new(
        "ReferenceSphere",
        1,
        "The exact relit diffuse sphere: (albedo/pi) * sum over every texel of L dOmega max(n.d, 0)",
        eval,
    )
    .output("image", IMAGE_T, "the exactly relit sphere")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .persist(Persist::Always)
    .into()
}

fn eval(ctx: &mut OpContext, p: ReferenceParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let env = &*p.env;
    check_finite(env)?;
    Ok(Value::new(reference_sphere(env, &sphere_view(p.size, p.view), p.albedo.0)))
}
