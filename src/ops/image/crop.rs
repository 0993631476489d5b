//! `Crop(image, x: 0, y: 0, width, height)`: the `width` x `height` rectangle whose top-left
//! pixel is (x, y).
//!
//! out(i, j) = image(x + i, y + j) for 0 <= i < width, 0 <= j < height, every channel, bit for bit.
//!
//! The output size is checked against the engine's pixel budget at validation. The input's
//! size is known only when the node runs: a rectangle that does not fit inside the image is then
//! an error that names the image's size (nothing is padded or clamped).

use crate::data::Image;
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType, Persist};
use crate::engine::value::Value;
use crate::types::ty::*;

crate::params! {
    pub struct CropParams {
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
    OpSpec::new("Crop", "image", 1, "A rectangle of an image (x, y: its top-left pixel)")
        .input("image", ANY_IMAGE, "the image to crop")
        .output("image", OutputType::SameAsInput("image"), "the rectangle, same channels")
        .size(|_, p: CropParams| Some((p.width as u64, p.height as u64)))
        .persist(Persist::IfSmall)
        .code_hash(crate::op_code_hash!())
        .eval(eval)
}

/// The rectangle, or an error naming the image's size if it does not fit.
pub fn crop(img: &Image, p: &CropParams) -> Result<Image, OpError> {
    let fits = |o: usize, n: usize, size: usize| o.checked_add(n).is_some_and(|end| end <= size);
    if !fits(p.x, p.width, img.width) || !fits(p.y, p.height, img.height) {
        return Err(OpError::Invalid(format!(
            "the rectangle x {}..{}, y {}..{} does not fit inside the {}x{} image",
            p.x,
            p.x.saturating_add(p.width),
            p.y,
            p.y.saturating_add(p.height),
            img.width,
            img.height
        )));
    }
    let c = img.channels;
    let mut data = Vec::with_capacity(p.width * p.height * c);
    for j in p.y..p.y + p.height {
        data.extend_from_slice(&img.row(j)[p.x * c..(p.x + p.width) * c]);
    }
    Ok(Image::with_names(p.width, p.height, img.names.clone(), data))
}

fn eval(ctx: &mut OpContext, p: CropParams) -> Result<Value, OpError> {
    Ok(Value::new(crop(ctx.get("image"), &p)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(x: usize, y: usize, width: usize, height: usize) -> CropParams {
        CropParams { x, y, width, height }
    }

    #[test]
    fn crop_takes_the_rectangle_with_its_channels() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let img = Image::with_names(4, 3, names.clone(), (0..48).map(|v| v as f32).collect());
        let out = crop(&img, &params(1, 1, 2, 2)).unwrap();
        assert_eq!((out.width, out.height, out.names.clone()), (2, 2, names));
        for j in 0..2 {
            for i in 0..2 {
                assert_eq!(out.pixel(i, j), img.pixel(1 + i, 1 + j));
            }
        }
        assert_eq!(crop(&img, &params(0, 0, 4, 3)).unwrap(), img);
    }

    #[test]
    fn a_rectangle_outside_the_image_names_its_size() {
        let img = Image::new(4, 3, 1);
        let e = crop(&img, &params(3, 0, 2, 1)).unwrap_err().to_string();
        assert_eq!(e, "the rectangle x 3..5, y 0..1 does not fit inside the 4x3 image");
        assert!(crop(&img, &params(0, 1, 1, 3)).is_err());
        assert!(crop(&img, &params(usize::MAX, 0, 1, 1)).is_err());
    }
}
