//! `Statistics(image, percentiles: [1, 50, 99, 99.9], latlong: true)` -> `metrics`: the
//! luminance statistics of an image (`maths::stats::statistics`).
//!
//! Luminance is Rec. 709 (`0.2126 R + 0.7152 G + 0.0722 B`; a one-channel field is its own
//! luminance). With `latlong: true` every texel weighs its solid angle
//! `(2 pi / W)(pi / H) sin(theta)` (the midpoint rule), so the statistics are over the sphere;
//! `latlong: false` weighs every pixel 1. Fields, in order:
//!
//! - `mean`: the weighted mean luminance; `min`, `max`: the smallest and largest luminance;
//! - `p<P>` for each requested percentile `P` (`p1`, `p50`, `p99.9`, ...): the smallest texel
//!   luminance `v` whose cumulative weight `W(Y <= v)` reaches `P`% of the total (a relative
//!   slack of 1e-9 absorbs f64 rounding; luminances rounded to f32);
//! - `dynamic_range_stops`: `log2(P99.9 / P0.1)` of the texels of positive luminance (the same
//!   weights): robust to a few hot or dead texels; 0 when no texel is positive;
//! - `nan_count`, `inf_count` (texels with a NaN, else an infinite colour channel: counted and
//!   left out of every other field), `negative_count` (finite texels with a negative channel,
//!   kept). A map without a finite texel reports 0 for the other fields.
//!
//! Tests: against a naive sort of small maps (exact), a map 1 above the horizon and 0 below
//! (weighted median exactly at the boundary: 0, any p above 50 gives 1) and a row ramp against
//! the closed form `(1 - cos theta) / 2` (within one row).

use crate::engine::fields::Input;
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::stats::statistics::LuminanceSamples;
use crate::values::ty::*;
use crate::values::{Image, Metrics};

crate::params! {
    pub struct StatisticsParams {
        /// the image (a lat-long map when latlong is true)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// the luminance percentiles to report, each in [0, 100]
        #[range(0.0, 100.0)]
        pub percentiles: Vec<f64> = vec![1.0, 50.0, 99.0, 99.9],
        /// weigh texels by their solid angle (a lat-long map); false: every pixel weighs 1
        pub latlong: bool = true,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "Statistics",
        1,
        "Luminance mean, percentiles and dynamic range (solid-angle weighted), and counts of NaN, Inf and negative texels",
        eval,
    )
    .output("metrics", METRICS_T, "the statistics")
    .check(check)
    .into()
}

/// The metric name of percentile `p`: `p1`, `p99.9`.
pub fn percentile_name(p: f64) -> String {
    format!("p{}", p + 0.0)
}

fn check(_: &CheckContext, p: StatisticsParams<crate::engine::fields::Check>) -> Result<(), CheckProblem> {
    for (i, a) in p.percentiles.iter().enumerate() {
        if p.percentiles[..i].iter().any(|b| percentile_name(*b) == percentile_name(*a)) {
            return Err(CheckProblem::at(
                StatisticsParams::percentiles,
                format!("percentile {a} is listed twice in percentiles"),
            ));
        }
    }
    Ok(())
}

/// The statistics of the module documentation.
pub fn statistics(img: &Image, percentiles: &[f64], latlong: bool) -> Metrics {
    let s = LuminanceSamples::new(img, latlong);
    let (min, max) = s.min_max().unwrap_or((0.0, 0.0));
    let mut fields = vec![("mean".to_string(), s.mean), ("min".to_string(), min), ("max".to_string(), max)];
    for (p, v) in percentiles.iter().zip(s.percentiles(percentiles)) {
        fields.push((percentile_name(*p), v.unwrap_or(0.0)));
    }
    fields.push(("dynamic_range_stops".into(), s.dynamic_range_stops()));
    fields.push(("nan_count".into(), s.nan as f64));
    fields.push(("inf_count".into(), s.inf as f64));
    fields.push(("negative_count".into(), s.negative as f64));
    Metrics { fields }
}

fn eval(_: &mut OpContext, p: StatisticsParams) -> Result<Value, OpError> {
    Ok(Value::new(statistics(&p.image, &p.percentiles, p.latlong)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_and_names() {
        let img = Image::from_fn_rgb(16, 8, |x, _| [x as f32, x as f32, x as f32]);
        let m = statistics(&img, &[0.0, 50.0, 99.9], false);
        let names: Vec<&str> = m.fields.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "mean",
                "min",
                "max",
                "p0",
                "p50",
                "p99.9",
                "dynamic_range_stops",
                "nan_count",
                "inf_count",
                "negative_count"
            ]
        );
        assert!((m.get("mean").unwrap() - 7.5).abs() < 1e-6);
        assert_eq!((m.get("min"), m.get("max"), m.get("p0")), (Some(0.0), Some(15.0), Some(0.0)));
        // 8 of 16 columns at or below 7: the lower median.
        assert!((m.get("p50").unwrap() - 7.0).abs() < 1e-6);
        // Positive texels 1..15, uniform: P0.1 = 1, P99.9 = 15.
        assert!((m.get("dynamic_range_stops").unwrap() - 15f64.log2()).abs() < 1e-6);
        assert_eq!(percentile_name(1.0), "p1");
        assert_eq!(percentile_name(0.1), "p0.1");
        assert_eq!(percentile_name(-0.0), "p0");
    }
}
