//! `Exposure(image, stops)`: multiply every value by 2^stops (the smallest operator: a template).
//!
//! out = v * 2^stops for every channel except alpha: in an image of two or more channels, the
//! channel named `A` is coverage, not light, and passes through unchanged (a scalar field is
//! always scaled, whatever its name).

use rayon::prelude::*;

use crate::data::Image;
use crate::engine::fields::{Check, Input};
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::value::Value;
use crate::types::ty::*;

crate::params! {
    pub struct ExposureParams {
        /// the image to scale
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// exposure change in stops (+1 doubles)
        #[range(-126.0, 126.0)]
        pub stops: f64,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new("Exposure", "image", 2, "Scale an image by 2^stops (alpha unchanged)")
        .output_like("image", |p: ExposureParams<Check>| p.image, "the scaled image")
        .size(|_, p: ExposureParams<Check>| p.image.size)
        .persist(Persist::IfSmall)
        .code_hash(crate::op_code_hash!())
        .eval(eval)
}

/// Scales every sample but alpha by 2^stops, in place.
pub fn expose(img: &mut Image, stops: f64) {
    let scale = 2f64.powf(stops) as f32;
    let c = img.channels;
    match img.channel_index("A").filter(|_| c > 1) {
        None => img.data.par_iter_mut().for_each(|v| *v *= scale),
        Some(alpha) => img.data.par_chunks_exact_mut(c).for_each(|px| {
            for (k, v) in px.iter_mut().enumerate() {
                if k != alpha {
                    *v *= scale;
                }
            }
        }),
    }
}

fn eval(_: &mut OpContext, p: ExposureParams) -> Result<Value, OpError> {
    // The input's buffer is reused when this node is its last consumer.
    let mut out = p.image.take();
    expose(&mut out, p.stops);
    Ok(Value::new(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_colour_and_leaves_alpha() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let mut img = Image::with_names(1, 2, names, vec![1.0, 2.0, 3.0, 0.5, 4.0, 5.0, 6.0, 1.0]);
        expose(&mut img, 1.0);
        assert_eq!(img.data, vec![2.0, 4.0, 6.0, 0.5, 8.0, 10.0, 12.0, 1.0]);
        let mut rgb = Image::from_vec(1, 1, 3, vec![1.0, 2.0, 4.0]);
        expose(&mut rgb, -2.0);
        assert_eq!(rgb.data, vec![0.25, 0.5, 1.0]);
        // A one-channel field named A is scaled: it is the data, not another image's alpha.
        let mut a = Image::with_names(1, 1, vec!["A".into()], vec![0.5]);
        expose(&mut a, 1.0);
        assert_eq!(a.data, vec![1.0]);
    }
}
