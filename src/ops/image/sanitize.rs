//! `Sanitize(image, replace: false)`: count the texels with a NaN or infinite value; with none,
//! the image passes through unchanged. Otherwise `replace: false` is an error naming the count
//! and the first such texel, and `replace: true` replaces them, with one warning naming the
//! count: NaN and -Inf become 0 (as `BuildCdf`'s `sanitize` makes them), +Inf the largest finite
//! value of its channel in the image (`BuildCdf` uses the largest float, harmless for a
//! sampling weight but a radiance that would swamp every filtered level: one such texel in a cube
//! would make the roughest levels 1e38). Every channel, alpha included, is checked.
//!
//! Meant in front of a bake (`hdrflow bake --sanitize` sets `replace`): the image operators fail
//! on the first non-finite texel without a count.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct SanitizeParams {
        /// the image to check
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// false: NaN or infinite texels are an error naming their count; true: replace them (NaN, -Inf -> 0; +Inf -> the channel's largest finite value)
        pub replace: bool = false,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Sanitize", 1, "Count NaN and infinite texels: an error naming the count, or replace them", eval)
        .output_like("image", |p| p.image, "the image with finite values only")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .into()
}

/// The number of texels with a non-finite value and the first of them (x, y, value).
pub fn non_finite(img: &Image) -> (usize, Option<(usize, usize, f32)>) {
    let c = img.channels.max(1);
    let mut first = None;
    let mut count = 0;
    for (t, px) in img.data.chunks(c).enumerate() {
        if let Some(&v) = px.iter().find(|v| !v.is_finite()) {
            count += 1;
            first.get_or_insert((t % img.width.max(1), t / img.width.max(1), v));
        }
    }
    (count, first)
}

/// Replaces NaN and -Inf with 0 and +Inf with the largest finite value of its channel (0 when
/// the channel has none), in place.
pub fn replace_non_finite(img: &mut Image) {
    let c = img.channels.max(1);
    let mut largest = vec![0.0f32; c];
    for px in img.data.chunks(c) {
        for (m, &v) in largest.iter_mut().zip(px) {
            if v.is_finite() && v > *m {
                *m = v;
            }
        }
    }
    for px in img.data.chunks_mut(c) {
        for (v, &m) in px.iter_mut().zip(&largest) {
            if *v == f32::INFINITY {
                *v = m;
            } else if !v.is_finite() {
                *v = 0.0;
            }
        }
    }
}

fn eval(ctx: &mut OpContext, p: SanitizeParams) -> Result<Value, OpError> {
    let (count, first) = non_finite(&p.image);
    let Some((x, y, v)) = first else { return Ok(Value::new(p.image.take())) };
    let texels = if count == 1 { "1 texel is".to_string() } else { format!("{count} texels are") };
    if !p.replace {
        return Err(OpError::Invalid(format!(
            "{texels} NaN or infinite (the first at ({x}, {y}): {v}): pass --sanitize (Sanitize(replace: true)) \
             to replace NaN and -Inf with 0 and +Inf with the largest finite value"
        )));
    }
    ctx.warn(format!(
        "replaced {count} NaN or infinite texel{} (the first at ({x}, {y}): {v}): NaN and -Inf with 0, +Inf with the \
         channel's largest finite value",
        if count == 1 { "" } else { "s" }
    ));
    let mut img = p.image.take();
    replace_non_finite(&mut img);
    Ok(Value::new(img))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_replaces_non_finite_texels() {
        let mut img =
            Image::from_vec(3, 1, 3, vec![1.0, f32::NAN, 2.0, 5.0, 4.0, 3.0, f32::INFINITY, 0.5, f32::NEG_INFINITY]);
        let (count, first) = non_finite(&img);
        assert_eq!(count, 2);
        assert_eq!(first.map(|(x, y, _)| (x, y)), Some((0, 0)));
        replace_non_finite(&mut img);
        assert_eq!(img.data, vec![1.0, 0.0, 2.0, 5.0, 4.0, 3.0, 5.0, 0.5, 0.0]);
        assert_eq!(non_finite(&img), (0, None));
    }
}
