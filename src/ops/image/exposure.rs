//! `Exposure(image, stops)`: multiply every value by 2^stops (the smallest operator: a template).

use rayon::prelude::*;

use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};

pub static SPEC: OpSpec = OpSpec {
    name: "Exposure",
    category: "image",
    version: 1,
    doc: "Scale an image by 2^stops",
    fields: &[
        FieldSpec::input("image", &[ValueType::Image, ValueType::ScalarField], "the image to scale"),
        FieldSpec {
            name: "stops",
            kind: FieldKind::Float { min: -126.0, max: 126.0 },
            default: Default::Required,
            doc: "exposure change in stops (+1 doubles)",
        },
    ],
    output: OutputType::SameAsInput("image"),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let scale = 2f64.powf(ctx.params.f64("stops")) as f32;
    let mut out = (**ctx.image("image")).clone();
    out.data.par_iter_mut().for_each(|v| *v *= scale);
    Ok(Value::image(out))
}
