//! `FlipVertical(image)`: reverse the row order (e.g. pbrt's upside-down lat-long maps).

use crate::engine::op::{FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};

pub static SPEC: OpSpec = OpSpec {
    name: "FlipVertical",
    category: "image",
    version: 1,
    doc: "Flip an image upside down",
    fields: &[FieldSpec::input("image", &[ValueType::Image, ValueType::ScalarField], "the image to flip")],
    output: OutputType::SameAsInput("image"),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    Ok(Value::image(ctx.image("image").flipped_vertical()))
}
