//! Robertson, Borman and Stevenson's response recovery ("Estimation-theoretic approach to
//! dynamic range enhancement using multiple exposures", J. Electronic Imaging 12(2), 2003), as
//! OpenCV's `CalibrateRobertson` iterates it, per channel, over every pixel:
//!
//! 1. start from the linear response `x(z) = z / 128`;
//! 2. radiance per pixel, `E = sum_j w(z_j) t_j x(z_j) / sum_j w(z_j) t_j^2` (OpenCV's
//!    `MergeRobertson`), `w` the Gaussian-like weight (`merge::Weight::Gaussian`, 0 at both ends);
//! 3. each code's new exposure is the mean of `t_j E` over the (pixel, frame) pairs showing it;
//! 4. normalise so `x(128) = 1`; stop when `sum_z |x_new - x| / 3 < threshold` (summed over the
//!    channels, OpenCV's measure) or after `max_iter` iterations.
//!
//! Two departures from OpenCV, both for pixels OpenCV turns into NaN or bias: a pixel whose
//! weights sum to 0 (clipped or black in every frame) has no radiance and joins no code's mean
//! (OpenCV counts it with `E = 0`, pulling `x(255)` towards 0), and a code no pixel shows takes
//! the value interpolated between its nearest seen neighbours (OpenCV divides 0 by 0). 16-bit
//! codes are binned to 256 and expanded as `debevec::expand` does, which also makes the
//! result non-decreasing.

use rayon::prelude::*;

use super::debevec::expand;
use super::merge::{weight, Weight};
use super::response::Response;
use crate::values::brackets::Brackets;

/// The response of `b`'s camera by Robertson's iteration (see the module documentation).
pub fn robertson(b: &Brackets, max_iter: usize, threshold: f64) -> Result<Response, String> {
    let shift = b.bit_depth - 8;
    let w: Vec<f64> = (0..256).map(|z| weight(Weight::Gaussian, z, 255, 1.0, 1.0)).collect();
    let times: Vec<f64> = b.frames.iter().map(|f| f.time).collect();
    let mut x: [Vec<f64>; 3] = std::array::from_fn(|_| (0..256).map(|z| z as f64 / 128.0).collect());
    let width = b.width;
    for _ in 0..max_iter {
        // Per channel and code: (sum of t E, count).
        let (sum, count) = (0..b.height)
            .into_par_iter()
            .fold(
                || (vec![0.0f64; 768], vec![0u64; 768]),
                |(mut sum, mut count), y| {
                    for i in y * width * 3..(y + 1) * width * 3 {
                        let c = i % 3;
                        let (mut num, mut den) = (0.0, 0.0);
                        for (f, t) in times.iter().enumerate() {
                            let z = (b.frames[f].codes.get(i) >> shift) as usize;
                            num += w[z] * t * x[c][z];
                            den += w[z] * t * t;
                        }
                        if den <= 0.0 {
                            continue;
                        }
                        let e = num / den;
                        for (f, t) in times.iter().enumerate() {
                            let z = (b.frames[f].codes.get(i) >> shift) as usize;
                            sum[c * 256 + z] += t * e;
                            count[c * 256 + z] += 1;
                        }
                    }
                    (sum, count)
                },
            )
            .reduce(
                || (vec![0.0; 768], vec![0; 768]),
                |(mut s, mut n), (s2, n2)| {
                    s.iter_mut().zip(s2).for_each(|(a, b)| *a += b);
                    n.iter_mut().zip(n2).for_each(|(a, b)| *a += b);
                    (s, n)
                },
            );
        let mut diff = 0.0;
        for c in 0..3 {
            let seen: Vec<usize> = (0..256).filter(|&z| count[c * 256 + z] > 0).collect();
            if seen.is_empty() {
                return Err("no pixel has a usable code in any frame".into());
            }
            let mean = |z: usize| sum[c * 256 + z] / count[c * 256 + z] as f64;
            let new: Vec<f64> = (0..256)
                .map(|z| {
                    if count[c * 256 + z] > 0 {
                        return mean(z);
                    }
                    let below = seen.iter().rev().find(|&&s| s < z);
                    let above = seen.iter().find(|&&s| s > z);
                    match (below, above) {
                        (Some(&a), Some(&b)) => mean(a) + (mean(b) - mean(a)) * (z - a) as f64 / (b - a) as f64,
                        (Some(&a), None) => mean(a),
                        (None, Some(&b)) => mean(b) * z as f64 / b as f64,
                        (None, None) => 0.0,
                    }
                })
                .collect();
            let mid = new[128];
            if !(mid > 0.0 && mid.is_finite()) {
                return Err(format!("channel {}: no exposure at the middle code", ["R", "G", "B"][c]));
            }
            let new: Vec<f64> = new.iter().map(|v| v / mid).collect();
            diff += new.iter().zip(&x[c]).map(|(a, b)| (a - b).abs()).sum::<f64>() / 3.0;
            x[c] = new;
        }
        if diff < threshold {
            break;
        }
    }
    Ok(expand(x, b.bit_depth))
}
