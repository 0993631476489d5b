//! The lighting-estimation protocol's tonemap (`stylelight/tonemap.py` of
//! DiffusionLight/DiffusionLight-evaluation, its `util.TonemapHDR(gamma=2.4, percentile=50,
//! max_mapping=0.5)` called with `clip=False`), applied to every map before its spheres are rendered:
//!
//!   out = alpha x^(1/gamma),  alpha = max_mapping / (P + 1e-10),
//!
//! where P is numpy's `percentile` (linear interpolation) of the samples of x^(1/gamma) above 0,
//! over every pixel and channel (all of them when none is above 0). Where the script gives NaN
//! (a negative or NaN sample: `np.power` of it), this gives 0 and counts the sample.
//! `tests/evaluation_metrics.rs` checks the result against the script's own `TonemapHDR`
//! (vendored in `bench/peers/tonemap_peer.py`) to 1e-6 relative.

use super::protocol_metrics::numpy_percentile;

/// The result of [`protocol_tonemap`]: the scale `alpha` and how many samples were not
/// finite and non-negative (set to 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProtocolTonemap {
    pub alpha: f64,
    pub bad_samples: usize,
}

/// Tonemaps `samples` in place (module docs): each becomes `alpha * x^(1/gamma)`.
pub fn protocol_tonemap(samples: &mut [f32], gamma: f64, percentile: f64, max_mapping: f64) -> ProtocolTonemap {
    let mut bad_samples = 0;
    let powered: Vec<f64> = samples
        .iter()
        .map(|&x| {
            if x.is_finite() && x >= 0.0 {
                (x as f64).powf(1.0 / gamma)
            } else {
                bad_samples += 1;
                0.0
            }
        })
        .collect();
    let mut positive: Vec<f64> = powered.iter().copied().filter(|&v| v > 0.0).collect();
    let p = if positive.is_empty() {
        numpy_percentile(&mut powered.clone(), percentile)
    } else {
        numpy_percentile(&mut positive, percentile)
    };
    let alpha = max_mapping / (p.unwrap_or(0.0) + 1e-10);
    for (s, v) in samples.iter_mut().zip(&powered) {
        *s = (alpha * v) as f32;
    }
    ProtocolTonemap { alpha, bad_samples }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_the_powered_samples_maps_to_max_mapping() {
        // Powered samples 1, 2, 3 (x = v^2.4) and a zero, which the percentile ignores: the
        // median of 1, 2, 3 is 2, so alpha = 0.5 / 2 and the samples become v / 4 (to the f32
        // rounding of x, 6e-8 relative).
        let mut s: Vec<f32> = [0.0f64, 1.0, 2.0, 3.0].iter().map(|v| v.powf(2.4) as f32).collect();
        let t = protocol_tonemap(&mut s, 2.4, 50.0, 0.5);
        assert!((t.alpha - 0.25).abs() < 3e-8, "{t:?}");
        for (got, want) in s.iter().zip([0.0, 0.25, 0.5, 0.75]) {
            assert!((got - want).abs() < 1e-6, "{got} vs {want}");
        }
        assert_eq!(t.bad_samples, 0);
    }

    #[test]
    fn negative_and_nan_samples_become_zero_and_are_counted() {
        let mut s = [f32::NAN, -1.0, 1.0, f32::INFINITY];
        let t = protocol_tonemap(&mut s, 2.4, 50.0, 0.5);
        assert_eq!(t.bad_samples, 3);
        assert_eq!(s, [0.0, 0.0, 0.5, 0.0].map(|v: f64| (v / (1.0 + 1e-10)) as f32));
    }

    #[test]
    fn a_black_image_stays_black() {
        let mut s = [0.0f32; 6];
        let t = protocol_tonemap(&mut s, 2.4, 50.0, 0.5);
        assert_eq!(s, [0.0; 6]);
        assert!(t.alpha.is_finite());
    }
}
