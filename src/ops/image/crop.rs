//! `Crop(image, x: 0, y: 0, width, height)`: the `width` x `height` rectangle whose top-left
//! pixel is (x, y).
//!
//! out(i, j) = image(x + i, y + j) for 0 <= i < width, 0 <= j < height, every channel, bit for bit.
//!
//! The output size is checked against the engine's pixel budget at validation. The input's
//! size is known only when the node runs: a rectangle that does not fit inside the image is then
//! an error that names the image's size (nothing is padded or clamped).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct CropParams {
        /// the image to crop
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// left column of the rectangle (0 is the left edge)
        #[range(0, 1 << 28)]
        pub x: usize = 0,
        /// top row of the rectangle (0 is the top edge)
        #[range(0, 1 << 28)]
        pub y: usize = 0,
        /// width of the rectangle in pixels
        #[range(1, 1 << 28)]
        pub width: usize,
        /// height of the rectangle in pixels
        #[range(1, 1 << 28)]
        pub height: usize,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Crop", 1, "A rectangle of an image (x, y: its top-left pixel)", eval)
        .output_like("image", |p| p.image, "the rectangle, same channels")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .persist(Persist::IfSmall)
        .into()
}

/// The `width` x `height` rectangle whose top-left pixel is (x, y), or an error naming the
/// image's size if it does not fit.
pub fn crop(img: &Image, x: usize, y: usize, width: usize, height: usize) -> Result<Image, OpError> {
    let fits = |o: usize, n: usize, size: usize| o.checked_add(n).is_some_and(|end| end <= size);
    if !fits(x, width, img.width) || !fits(y, height, img.height) {
        return Err(OpError::Invalid(format!(
            "the rectangle x {}..{}, y {}..{} does not fit inside the {}x{} image",
            x,
            x.saturating_add(width),
            y,
            y.saturating_add(height),
            img.width,
            img.height
        )));
    }
    let c = img.channels;
    let mut data = Vec::with_capacity(width * height * c);
    for j in y..y + height {
        data.extend_from_slice(&img.row(j)[x * c..(x + width) * c]);
    }
    Ok(Image::with_names(width, height, img.names.clone(), data))
}

fn eval(_: &mut OpContext, p: CropParams) -> Result<Value, OpError> {
    Ok(Value::new(crop(&p.image, p.x, p.y, p.width, p.height)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_takes_the_rectangle_with_its_channels() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let img = Image::with_names(4, 3, names.clone(), (0..48).map(|v| v as f32).collect());
        let out = crop(&img, 1, 1, 2, 2).unwrap();
        assert_eq!((out.width, out.height, out.names.clone()), (2, 2, names));
        for j in 0..2 {
            for i in 0..2 {
                assert_eq!(out.pixel(i, j), img.pixel(1 + i, 1 + j));
            }
        }
        assert_eq!(crop(&img, 0, 0, 4, 3).unwrap(), img);
    }

    #[test]
    fn a_rectangle_outside_the_image_names_its_size() {
        let img = Image::new(4, 3, 1);
        let e = crop(&img, 3, 0, 2, 1).unwrap_err().to_string();
        assert_eq!(e, "the rectangle x 3..5, y 0..1 does not fit inside the 4x3 image");
        let e = crop(&img, 0, 1, 1, 3).unwrap_err();
        assert!(
            matches!(&e, OpError::Invalid(m) if m == "the rectangle x 0..1, y 1..4 does not fit inside the 4x3 image"),
            "{e}"
        );
        // x + width overflows: refused, not wrapped around.
        let e = crop(&img, usize::MAX, 0, 1, 1).unwrap_err();
        assert!(matches!(&e, OpError::Invalid(m) if m.ends_with("does not fit inside the 4x3 image")), "{e}");
    }
}
