//! `SgToLatLong(lobes, width: 512, height: 256)`: spherical Gaussian lobes rendered into a
//! `width x height` RGB lat-long map (`maths::fit::spherical_gaussians::render`), to compare a fit
//! with its map (`Difference`) or save it.
//!
//! Each texel is `sum_k a_k exp(lambda_k (mu_k . d - 1))` at its centre direction `d`
//! (hdrflow's lat-long convention), rounded to f32. A lobe's integral is
//! `2 pi a (1 - exp(-2 lambda)) / lambda`; the rendered map's midpoint sum
//! `sum_t L(d_t) Omega_t` meets it to within twice the grid's own excess over 4 pi,
//! `pi^2 / (24 H^2)` relative (tested from lambda = 0.05 to 5000; measured in
//! `docs/src/guides/toolkit/spherical_gaussians.md`).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::fit::spherical_gaussians::render;
use crate::values::ty::*;
use crate::values::SphericalGaussians;

crate::params! {
    pub struct SgToLatLongParams {
        /// the lobes to render
        #[input(&[SG_T])]
        pub lobes: Input<SphericalGaussians>,
        /// output width
        #[range(1, 1 << 28)]
        pub width: usize = 512,
        /// output height
        #[range(1, 1 << 28)]
        pub height: usize = 256,
    }
}

pub fn spec() -> OpSpec {
    Op::new("SgToLatLong", 1, "Spherical Gaussian lobes rendered into an RGB lat-long map", eval)
        .output("image", IMAGE_T, "the lobes' radiance at each texel centre")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .into()
}

fn eval(_: &mut OpContext, p: SgToLatLongParams) -> Result<Value, OpError> {
    Ok(Value::new(render(&p.lobes, p.width, p.height)))
}
