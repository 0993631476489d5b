//! `BuildCdf(luminance, sin_theta: true, sanitize: false)`: the 2D piecewise-constant
//! distribution of a lat-long luminance map (see `data::distribution` for the maths and for what
//! zero rows, black maps, NaN/Inf/negative texels and 1xN maps do).

use crate::data::Distribution2D;
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};

pub static SPEC: OpSpec = OpSpec {
    name: "BuildCdf",
    category: "sampling",
    version: 1,
    doc: "Importance-sampling distribution of a lat-long map: marginal over rows, conditional per row (f64)",
    fields: &[
        FieldSpec::input("luminance", &[ValueType::ScalarField], "the lat-long luminance (Luminance of the map)"),
        FieldSpec {
            name: "sin_theta",
            kind: FieldKind::Bool,
            default: Default::Bool(true),
            doc: "weight texels by sin(theta), their solid angle; false reproduces the seed's comparison",
        },
        FieldSpec {
            name: "sanitize",
            kind: FieldKind::Bool,
            default: Default::Bool(false),
            doc: "treat NaN and negative texels as 0 and +Inf as the largest float instead of failing",
        },
    ],
    output: OutputType::Fixed(ValueType::Distribution),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let lum = ctx.image("luminance");
    let dist = Distribution2D::build(lum, ctx.params.bool("sin_theta"), ctx.params.bool("sanitize"))
        .map_err(|e| OpError::Invalid(e.to_string()))?;
    Ok(Value::Distribution(std::sync::Arc::new(dist)))
}
