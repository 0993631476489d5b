//! `Constant(width, height, color)`: an image of one colour (a canvas for `Overlay`, or a
//! constant environment whose relit sphere is exactly albedo * color).

use crate::data::Image;
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};

pub static SPEC: OpSpec = OpSpec {
    name: "Constant",
    category: "image",
    version: 1,
    doc: "An image of a single colour (canvas, or a constant environment)",
    fields: &[
        FieldSpec {
            name: "width",
            kind: FieldKind::Int { min: 1, max: 1 << 15 },
            default: Default::Int(512),
            doc: "width in pixels",
        },
        FieldSpec {
            name: "height",
            kind: FieldKind::Int { min: 1, max: 1 << 15 },
            default: Default::Int(256),
            doc: "height in pixels",
        },
        FieldSpec {
            name: "color",
            kind: FieldKind::Tuple { len: 3, min: -3.0e38, max: 3.0e38 },
            default: Default::Tuple(&[0.0, 0.0, 0.0]),
            doc: "linear RGB value of every pixel",
        },
    ],
    output: OutputType::Fixed(ValueType::Image),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let (w, h) = (ctx.params.usize("width"), ctx.params.usize("height"));
    let c = ctx.params.vec3("color").map(|v| v as f32);
    Ok(Value::image(Image::from_fn_rgb(w, h, |_, _| c)))
}
