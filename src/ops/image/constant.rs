//! `Constant(width, height, color)`: an image of one colour (a canvas for `Overlay`, or a
//! constant environment whose relit sphere is exactly albedo * color).

use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct ConstantParams {
        /// width in pixels
        #[range(1, 1 << 28)]
        pub width: usize = 512,
        /// height in pixels
        #[range(1, 1 << 28)]
        pub height: usize = 256,
        /// linear RGB value of every pixel (a single number means grey)
        #[range(-3.0e38, 3.0e38)]
        pub color: Rgb = Rgb([0.0, 0.0, 0.0]),
    }
}

pub fn spec() -> OpSpec {
    Op::new("Constant", 1, "An image of a single colour (canvas, or a constant environment)", eval)
        .output("image", IMAGE_T, "the image")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .persist(Persist::IfSmall)
        .into()
}

fn eval(_: &mut OpContext, p: ConstantParams) -> Result<Value, OpError> {
    let c = p.color.f32();
    Ok(Value::new(Image::from_fn_rgb(p.width, p.height, |_, _| c)))
}
