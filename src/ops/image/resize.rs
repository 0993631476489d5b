//! `Resize(image, width, height)`: area-averaging, energy-preserving resample
//! (`maths::resample::area_resize`: a box filter with exact fractional coverage; the image mean is
//! unchanged, for shrinking and enlarging alike). Every channel is averaged alike, alpha
//! included, and the channel names are kept.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::resample::area_resize;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct ResizeParams {
        /// the image to resize
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// output width
        #[range(1, 1 << 28)]
        pub width: usize,
        /// output height
        #[range(1, 1 << 28)]
        pub height: usize,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Resize", 1, "Area-averaging, energy-preserving resize", eval)
        .output_like("image", |p| p.image, "the resized image")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .into()
}

fn eval(_: &mut OpContext, p: ResizeParams) -> Result<Value, OpError> {
    // At its own size the image is its own box-filtered mean (one tap of weight 1, exact in f64):
    // passed on, not copied.
    if (p.image.width, p.image.height) == (p.width, p.height) {
        return Ok(p.image.into_value());
    }
    Ok(Value::new(area_resize::resize(&p.image, p.width, p.height)))
}
