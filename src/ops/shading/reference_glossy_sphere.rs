//! `ReferenceGlossySphere(env, exponent: 10, diffuse: 0.2, specular: 0.8, size: 256, view:
//! (90, 90))`: the exact answer for `GlossySphere`'s BRDF on the piecewise-constant map, the
//! sum over every texel `Lo = sum_i L_i f(d_i) max(n.d_i, 0) dOmega_i` (texel centres, midpoint
//! solid angles, f64; `maths::render::glossy`), 0 off the disc. Under a constant map of radiance 1 the
//! centre pixel (seen along its normal) is `diffuse + specular` (within 1e-3 on a 1024 x 512
//! map, the test's bound). `GlossySphere` converges to the same integral over exact texel
//! areas, which differs by the midpoint rule (O(s h^2), h the texel angle).
//!
//! Cost: O(pixels x non-zero texels), no culling (a 128 x 128 sphere under a 512 x 256 map is
//! ~1.7e9 terms: seconds on 2 cores).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::render::glossy::{reference_glossy_sphere, GlossyBrdf};
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;

super::glossy_params! {
    ReferenceGlossyParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
    } {}
}

pub fn spec() -> OpSpec {
    Op::new("ReferenceGlossySphere", 1, "The exact modified-Phong sphere: sum over every texel of L f cos dOmega", eval)
        .output("image", IMAGE_T, "the exact glossy sphere")
        .size(|_, p| Some((p.size as u64, p.size as u64)))
        .into()
}

fn eval(ctx: &mut OpContext, p: ReferenceGlossyParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let env = &*p.env;
    check_finite(env)?;
    let brdf = GlossyBrdf { diffuse: p.diffuse.0, specular: p.specular.0, exponent: p.exponent };
    Ok(Value::new(reference_glossy_sphere(env, &super::sphere_view(p.size, p.view), &brdf)))
}
