//! `ShIrradiance(env, order: 2)`: the real spherical-harmonic coefficients
//! `L_lm = sum_texels L Y_lm(d) dOmega` of the map up to band `order`, per channel, as a metrics
//! record (save it as `.json`). Fields `L_{l}_{m}_{r|g|b}` in the order l = 0.., m = -l..l, then
//! r, g, b (e.g. `L_0_0_r`, `L_1_-1_g`). With `order: 2` these are the 9 coefficients of
//! Ramamoorthi and Hanrahan's irradiance environment map (SIGGRAPH 2001); the basis
//! (normalisation, signs, and which axes x, y, z are in the lat-long frame) is documented in
//! `maths::sh`.

use super::reference_sphere::check_finite;
use crate::data::Image;
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::Value;
use crate::types::ty::*;

use crate::data::Metrics;
use crate::maths::sh::{coefficient_name, project, sh_lm};

crate::params! {
    pub struct ShIrradianceParams {
        /// highest band l
        #[range(0, 32)]
        pub order: usize = 2,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new(
        "ShIrradiance",
        "shading",
        1,
        "Spherical-harmonic coefficients L_lm of a lat-long map (order 2: Ramamoorthi-Hanrahan's 9)",
    )
    .input("env", &[IMAGE_T], "the lat-long environment (linear RGB)")
    .output("coefficients", OutputType::Fixed(METRICS_T), "the coefficients L_l_m_channel")
    .code(crate::this_file!())
    .eval(eval)
}

fn eval(ctx: &mut OpContext, p: ShIrradianceParams) -> Result<Value, OpError> {
    let env: &Image = ctx.get("env");
    check_finite(env)?;
    let coeffs = project(env, p.order);
    let mut fields = Vec::with_capacity(coeffs.len() * 3);
    for (i, c) in coeffs.iter().enumerate() {
        let (l, m) = sh_lm(i);
        for (ch, &v) in c.iter().enumerate() {
            fields.push((coefficient_name(l, m, ch), v));
        }
    }
    Ok(Value::new(Metrics { fields }))
}
