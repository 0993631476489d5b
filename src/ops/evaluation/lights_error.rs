//! `LightsError(pred, gt, top_k: 5)`: the angular error between the dominant lights of a
//! predicted map and of its truth, as EnvMapNet's metric computes it (Somanath and Kurz, CVPR
//! 2021; `envmapnet/ParametricLights.py` `calculate_angular_error_metric`, as
//! `DiffusionLight/DiffusionLight-evaluation` runs it): a set with one light counts it twice;
//! `k = min(top_k, |gt|, |pred|)`; the first `k` lights of each set (most energetic first, as
//! `ExtractLights` orders them) are matched both ways, each to the nearest of the other's first
//! `k` by the angle between their directions (`2 asin(|d1 - d2| / 2)`), and the `2k` angles
//! are averaged. Output in degrees (the script's average is in radians, turned into degrees
//! after averaging over maps).
//!
//! The lights themselves come from `ExtractLights`, not from the script's blob finder (which
//! blurs, labels and fits ellipses with scikit-image and OpenCV, and whose luminance keeps only
//! the blue channel's term: `G = I[:,:,c]*rgb2gr[c]` overwrites instead of adding); the
//! metric, given the lights, is the script's. A set without any light has no error: the script
//! returns -1 and leaves the map out of its average; here `angular_error_deg` is -1 and
//! `defined` is 0, so a batch's summary can do the same.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::{Lights, Metrics};

crate::params! {
    pub struct LightsErrorParams {
        /// the lights of the prediction (ExtractLights)
        #[input(&[LIGHTS_T])]
        pub pred: Input<Lights>,
        /// the lights of the ground truth (ExtractLights)
        #[input(&[LIGHTS_T])]
        pub gt: Input<Lights>,
        /// how many of the most energetic lights of each set are matched
        #[range(1, 64)]
        pub top_k: usize = 5,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LightsError",
        1,
        "EnvMapNet's angular error (degrees) between the dominant lights of a prediction and of its truth",
        eval,
    )
    .output("metrics", METRICS_T, "angular_error_deg (-1 when a set has no light), defined (1 or 0), k")
    .into()
}

/// The angle between two directions, `2 asin(|a - b| / 2)` for unit vectors (the script's form,
/// accurate for small and large angles alike); the directions are normalised first.
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let unit = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.0 {
            v.map(|c| c / n)
        } else {
            v
        }
    };
    let (a, b) = (unit(a), unit(b));
    let chord = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    2.0 * (0.5 * chord).min(1.0).asin()
}

/// The metric in radians and the `k` used, or `None` when a set is empty (module docs).
pub fn angular_error(gt: &[[f64; 3]], pred: &[[f64; 3]], top_k: usize) -> Option<(f64, usize)> {
    if gt.is_empty() || pred.is_empty() {
        return None;
    }
    let twice = |s: &[[f64; 3]]| if s.len() < 2 { vec![s[0], s[0]] } else { s.to_vec() };
    let (gt, pred) = (twice(gt), twice(pred));
    let k = top_k.min(gt.len()).min(pred.len());
    let nearest = |a: [f64; 3], set: &[[f64; 3]]| set[..k].iter().map(|&b| angle(a, b)).fold(f64::INFINITY, f64::min);
    let sum: f64 = gt[..k].iter().map(|&g| nearest(g, &pred)).sum::<f64>()
        + pred[..k].iter().map(|&p| nearest(p, &gt)).sum::<f64>();
    Some((sum / (2 * k) as f64, k))
}

fn eval(_: &mut OpContext, p: LightsErrorParams) -> Result<Value, OpError> {
    let dirs = |l: &Lights| l.lights.iter().map(|l| l.direction).collect::<Vec<_>>();
    let (err, defined, k) = match angular_error(&dirs(&p.gt), &dirs(&p.pred), p.top_k) {
        Some((e, k)) => (e.to_degrees(), 1.0, k as f64),
        None => (-1.0, 0.0, 0.0),
    };
    let fields = vec![("angular_error_deg".to_string(), err), ("defined".to_string(), defined), ("k".to_string(), k)];
    Ok(Value::new(Metrics { fields }))
}

#[cfg(test)]
mod tests {
    use super::*;

    const X: [f64; 3] = [1.0, 0.0, 0.0];
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    const Z: [f64; 3] = [0.0, 0.0, 1.0];

    #[test]
    fn equal_sets_have_no_error_and_one_light_counts_twice() {
        assert_eq!(angular_error(&[X, Y], &[Y, X], 5), Some((0.0, 2)));
        // One light each, 90 degrees apart: every match is 90 degrees.
        let (e, k) = angular_error(&[X], &[Y], 5).unwrap();
        assert!((e - std::f64::consts::FRAC_PI_2).abs() < 1e-12 && k == 2);
    }

    #[test]
    fn matching_is_both_ways_over_the_first_k() {
        // gt {X, Y}, pred {X, Z}: X-X 0, Y-nearest 90, X-X 0, Z-nearest 90: mean 45 degrees.
        let (e, _) = angular_error(&[X, Y], &[X, Z], 5).unwrap();
        assert!((e.to_degrees() - 45.0).abs() < 1e-9, "{}", e.to_degrees());
        // top_k 1 only compares the first lights.
        assert_eq!(angular_error(&[X, Y], &[X, Z], 1), Some((0.0, 1)));
        // Opposite directions: 180 degrees, no NaN from rounding past the chord of 2.
        let (e, _) = angular_error(&[X], &[[-1.0, 1e-17, 0.0]], 5).unwrap();
        assert!((e.to_degrees() - 180.0).abs() < 1e-6);
        assert_eq!(angular_error(&[], &[X], 5), None);
    }
}
