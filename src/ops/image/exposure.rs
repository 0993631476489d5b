//! `Exposure(image, stops: 0)` or `Exposure(image, match_percentile: (p, value))`: multiply every
//! value by 2^stops (the smallest operator: a template), or by the factor that brings a
//! luminance percentile to a given value (datasets' exposure calibration).
//!
//! out = v * s for every channel except alpha: in an image of two or more channels, the
//! channel named `A` is coverage, not light, and passes through unchanged (a scalar field is
//! always scaled, whatever its name). `s = 2^stops` (rounded to f32), or, with
//! `match_percentile: (p, value)`, `s = value / P_p` (rounded to f32), where `P_p` is the
//! solid-angle-weighted p-th percentile of the Rec. 709 luminance of the lat-long map, as
//! `Statistics` computes it (`maths::stats::statistics`: the smallest texel luminance whose
//! cumulative solid angle reaches p%; NaN and infinite texels left out). So after scaling the
//! p-th percentile is `value` up to f32 rounding (the tests check 1e-6 relative). Giving both a
//! non-zero `stops` and `match_percentile` is a pipeline error, and so are `p` outside
//! [0, 100] and `value <= 0`; a map whose p-th percentile is not positive (or has no finite
//! texel) is a run error.

use rayon::prelude::*;

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::stats::statistics::latlong_percentile;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct ExposureParams {
        /// the image to scale
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// exposure change in stops (+1 doubles)
        #[range(-126.0, 126.0)]
        pub stops: f64 = 0.0,
        /// instead of stops: (p, value) scales so that the solid-angle-weighted p-th luminance percentile becomes value
        pub match_percentile: Option<[f64; 2]>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Exposure", 2, "Scale an image by 2^stops (alpha unchanged)", eval)
        .output_like("image", |p| p.image, "the scaled image")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .check(check)
        .into()
}

fn check(_: &CheckContext, p: ExposureParams<Check>) -> Result<(), CheckProblem> {
    let Some([pct, value]) = p.match_percentile else { return Ok(()) };
    if p.stops != 0.0 {
        return Err(CheckProblem::at(
            ExposureParams::match_percentile,
            "give either stops or match_percentile, not both",
        ));
    }
    if !(0.0..=100.0).contains(&pct) {
        return Err(CheckProblem::at(
            ExposureParams::match_percentile,
            format!("the percentile p = {pct} is outside [0, 100]"),
        ));
    }
    if !(value > 0.0) {
        return Err(CheckProblem::at(ExposureParams::match_percentile, format!("the value {value} must be positive")));
    }
    Ok(())
}

/// Scales every sample but alpha by 2^stops, in place.
pub fn expose(img: &mut Image, stops: f64) {
    scale_image(img, 2f64.powf(stops) as f32);
}

/// The factor `value / P_p` of `match_percentile: (p, value)` for `img` (see the module
/// documentation), or why there is none.
pub fn match_scale(img: &Image, p: f64, value: f64) -> Result<f32, String> {
    let Some(level) = latlong_percentile(img, p) else {
        return Err(format!("cannot match luminance percentile {p}: the image has no finite texel"));
    };
    if !(level > 0.0) {
        return Err(format!(
            "luminance percentile {p} of the image is {level}: only a positive percentile can be scaled to {value}"
        ));
    }
    let scale = (value / level) as f32;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(format!(
            "scaling luminance percentile {p} ({level:e}) to {value:e} needs a factor outside the f32 range"
        ));
    }
    Ok(scale)
}

/// Scales every sample but alpha by `scale`, in place.
pub fn scale_image(img: &mut Image, scale: f32) {
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
    let scale = match p.match_percentile {
        None => None,
        Some([pct, value]) => Some(match_scale(&p.image, pct, value).map_err(OpError::Invalid)?),
    };
    let mut out = p.image.take();
    match scale {
        None => expose(&mut out, p.stops),
        Some(s) => scale_image(&mut out, s),
    }
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

    #[test]
    fn match_percentile_scales_the_percentile_to_the_value() {
        // A row ramp: the weighted median is one row's value; after scaling it is the value.
        let (w, h) = (16, 64);
        let img = Image::from_fn_rgb(w, h, |_, y| [0.5 + y as f32, 0.25 + y as f32, 1.0 + y as f32]);
        for (p, value) in [(50.0, 0.18), (99.0, 1.0), (0.0, 3.0), (100.0, 1e4)] {
            let mut out = img.clone();
            scale_image(&mut out, match_scale(&img, p, value).unwrap());
            let got = latlong_percentile(&out, p).unwrap();
            assert!((got / value - 1.0).abs() < 1e-6, "p {p}: {got} vs {value}");
        }
        // A percentile of 0 (more than half black) cannot be scaled.
        let half = Image::from_fn_rgb(w, h, |_, y| if y < h / 2 { [1.0; 3] } else { [0.0; 3] });
        let e = match_scale(&half, 50.0, 0.18).unwrap_err();
        assert!(e.contains("luminance percentile 50 of the image is 0: only a positive"), "{e}");
        assert!(match_scale(&half, 60.0, 0.18).is_ok());
        let e = match_scale(&Image::from_vec(1, 1, 1, vec![f32::NAN]), 50.0, 1.0).unwrap_err();
        assert!(e.contains("no finite texel"), "{e}");
        let e = match_scale(&Image::from_vec(1, 1, 1, vec![1e-30]), 50.0, 1e30).unwrap_err();
        assert!(e.contains("outside the f32 range"), "{e}");
    }
}
