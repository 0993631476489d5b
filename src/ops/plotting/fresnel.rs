//! `Fresnel(eta_i, eta_t, steps: 901)`: exact dielectric reflectance for s and p polarisation
//! and their mean from 0 to 90 degrees, with the Brewster angle atan(eta_t/eta_i) and, when
//! eta_i > eta_t, the critical angle asin(eta_t/eta_i) in closed form (see `maths::fresnel`).

use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::maths::fresnel::fresnel_curves;

pub static SPEC: OpSpec = OpSpec {
    name: "Fresnel",
    category: "plotting",
    version: 1,
    doc: "Dielectric Fresnel reflectance curves (Rs, Rp, R) with exact Brewster and critical angles",
    fields: &[
        FieldSpec {
            name: "eta_i",
            kind: FieldKind::Float { min: 1e-6, max: 1e6 },
            default: Default::Float(1.0),
            doc: "refractive index of the incident medium",
        },
        FieldSpec {
            name: "eta_t",
            kind: FieldKind::Float { min: 1e-6, max: 1e6 },
            default: Default::Float(1.5),
            doc: "refractive index of the transmitting medium",
        },
        FieldSpec {
            name: "steps",
            kind: FieldKind::Int { min: 2, max: 1_000_000 },
            default: Default::Int(901),
            doc: "number of angles from 0 to 90 degrees inclusive",
        },
    ],
    output: OutputType::Fixed(ValueType::Curves),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let c = fresnel_curves(ctx.params.f64("eta_i"), ctx.params.f64("eta_t"), ctx.params.usize("steps"));
    Ok(Value::Curves(std::sync::Arc::new(c)))
}
