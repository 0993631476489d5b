//! `FlipVertical(image)`: reverse the row order (e.g. pbrt's upside-down lat-long maps).

use crate::data::Image;
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::params::NoParams;
use crate::engine::value::Value;
use crate::types::ty::*;

pub fn spec() -> OpSpec {
    OpSpec::new("FlipVertical", "image", 1, "Flip an image upside down")
        .input("image", ANY_IMAGE, "the image to flip")
        .output("image", OutputType::SameAsInput("image"), "the flipped image")
        .code(crate::this_file!())
        .eval(eval)
}

fn eval(ctx: &mut OpContext, _: NoParams) -> Result<Value, OpError> {
    let mut img: Image = ctx.take("image");
    img.flip_vertical_in_place();
    Ok(Value::new(img))
}
