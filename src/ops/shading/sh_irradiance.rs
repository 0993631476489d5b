//! `ShIrradiance(env, order: 2)`: the real spherical-harmonic coefficients
//! `L_lm = sum_texels L Y_lm(d) dOmega` of the map up to band `order`, per channel, as a metrics
//! record (save it as `.json`). Fields `L_{l}_{m}_{r|g|b}` in the order l = 0.., m = -l..l, then
//! r, g, b (e.g. `L_0_0_r`, `L_1_-1_g`). With `order: 2` these are the 9 coefficients of
//! Ramamoorthi and Hanrahan's irradiance environment map (SIGGRAPH 2001); the basis
//! (normalisation, signs, and which axes x, y, z are in the lat-long frame) is documented in
//! `maths::sh`.

use std::sync::Arc;

use crate::data::Metrics;
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::maths::sh::{coefficient_name, project, sh_lm};

use super::reference_sphere::check_finite;

pub static SPEC: OpSpec = OpSpec {
    name: "ShIrradiance",
    category: "shading",
    version: 1,
    doc: "Spherical-harmonic coefficients L_lm of a lat-long map (order 2: Ramamoorthi-Hanrahan's 9)",
    fields: &[
        FieldSpec::input("env", &[ValueType::Image], "the lat-long environment (linear RGB)"),
        FieldSpec {
            name: "order",
            kind: FieldKind::Int { min: 0, max: 32 },
            default: Default::Int(2),
            doc: "highest band l",
        },
    ],
    output: OutputType::Fixed(ValueType::Metrics),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let env = ctx.image("env");
    check_finite(env)?;
    let order = ctx.params.usize("order");
    let coeffs = project(env, order);
    let mut fields = Vec::with_capacity(coeffs.len() * 3);
    for (i, c) in coeffs.iter().enumerate() {
        let (l, m) = sh_lm(i);
        for (ch, &v) in c.iter().enumerate() {
            fields.push((coefficient_name(l, m, ch), v));
        }
    }
    Ok(Value::Metrics(Arc::new(Metrics { fields })))
}
