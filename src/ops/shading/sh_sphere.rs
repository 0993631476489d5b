//! `ShSphere(env, size: 256, albedo, view, order: 2)`: the diffuse sphere lit by the map's
//! spherical-harmonic irradiance approximation (Ramamoorthi and Hanrahan, "An Efficient
//! Representation for Irradiance Environment Maps", SIGGRAPH 2001):
//! `Lo(n) = (albedo / pi) sum_{l <= order} A_l sum_m L_lm Y_lm(n)` (`maths::ibl::sh`). Same `size`,
//! `albedo` and `view` fields and defaults as `RelightSphere`, so it compares pixel for pixel
//! with `ReferenceSphere`. Accurate (~1%) for smooth lighting at order 2; a small sun gives large
//! errors and rings, even negative values, which are kept (not clamped) so they can be measured.

use super::sphere_view;
use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::ibl::sh::sh_sphere;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;

super::sphere_params! {
    ShSphereParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
    } {
        /// highest SH band l (2: 9 coefficients)
        #[range(0, 32)]
        pub order: usize = 2,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "ShSphere",
        1,
        "Relight a diffuse sphere with the spherical-harmonic irradiance map (Ramamoorthi-Hanrahan)",
        eval,
    )
    .output("image", IMAGE_T, "the relit sphere")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: ShSphereParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let env = &*p.env;
    check_finite(env)?;
    Ok(Value::new(sh_sphere(env, &sphere_view(p.size, p.view), p.albedo.0, p.order)))
}
