//! `FlipVertical(image)`: reverse the row order (e.g. pbrt's upside-down lat-long maps).
//!
//! out(x, y) = image(x, H - 1 - y), every channel (alpha included) and its name kept.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct FlipVerticalParams {
        /// the image to flip
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("FlipVertical", 1, "Flip an image upside down", eval)
        .output_like("image", |p| p.image, "the flipped image")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .into()
}

fn eval(_: &mut OpContext, p: FlipVerticalParams) -> Result<Value, OpError> {
    let mut img = p.image.take();
    img.flip_vertical_in_place();
    Ok(Value::new(img))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgba_rows_swap_with_their_alpha_and_names() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let mut img = Image::with_names(1, 2, names.clone(), vec![1.0, 2.0, 3.0, 0.5, 4.0, 5.0, 6.0, 1.0]);
        img.flip_vertical_in_place();
        assert_eq!((img.names, img.data), (names, vec![4.0, 5.0, 6.0, 1.0, 1.0, 2.0, 3.0, 0.5]));
    }
}
