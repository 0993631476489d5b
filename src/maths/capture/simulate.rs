//! Synthetic brackets with a known truth: what a camera with a known response would write for
//! an HDR image, exposure by exposure. The truth for tests, benchmarks and the capture example.
//!
//! For frame `i` (exposure time `t_i`, integer shift `(dx_i, dy_i)`) and channel value `E` of
//! the image at pixel `(x - dx_i, y - dy_i)` (clamped to the image: the uncovered edge is filled
//! from the edge, as an aligned frame is), the sensor's linear exposure is `X = scale E t_i`
//! (1 = the clip; NaN and negative values read as 0). Noise, in the units where the clip is
//! 1: `X' = X + noise sqrt(X / W + (R / W)^2) n`, a full well of `W = 32768` electrons (shot
//! noise, Poisson approximated by a Gaussian) and a read noise of `R = 4` electrons (an APS-C
//! sensor at base ISO: about 13 stops), `n` a standard normal; `noise` scales both (0: none,
//! 1: that camera). The code is
//! `round(f(clamp(X', 0, 1)) max)`, `f` the known response ([`Known::encode`]).
//!
//! `n` is deterministic: Box-Muller on two uniforms from SplitMix64 of (seed, frame, sample
//! index), so the frames are the same on every run and thread count.

use rayon::prelude::*;

use super::response::{max_code, Known};
use crate::maths::sampling::sequences::{mix64, unit_f64, GOLDEN_GAMMA};
use crate::values::brackets::{Brackets, Codes, Frame};
use crate::values::Image;

/// Electrons at the clip.
pub const FULL_WELL: f64 = 32768.0;
/// Read noise, electrons.
pub const READ_NOISE: f64 = 4.0;

/// How to expose, noise and quantise the frames (see the module documentation).
#[derive(Clone, Debug)]
pub struct Simulation {
    pub times: Vec<f64>,
    pub curve: Known,
    pub bits: u8,
    pub noise: f64,
    pub seed: u64,
    /// One `(dx, dy)` per frame, or empty for none.
    pub shifts: Vec<(i64, i64)>,
    pub scale: f64,
}

/// A standard normal from (seed, frame, sample).
#[inline]
fn normal(seed: u64, frame: usize, i: usize) -> f64 {
    let k =
        mix64(seed ^ mix64((frame as u64).wrapping_mul(GOLDEN_GAMMA) ^ (i as u64).wrapping_mul(0x2545_F491_4F6C_DD1D)));
    let u1 = 1.0 - unit_f64(k); // (0, 1]
    let u2 = unit_f64(mix64(k ^ GOLDEN_GAMMA));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The frames of `image` (its first three channels) as the simulated camera writes them.
pub fn simulate(image: &Image, sim: &Simulation) -> Result<Brackets, String> {
    if image.channels < 3 {
        return Err(format!("the image has {} channels; brackets are RGB", image.channels));
    }
    if !sim.shifts.is_empty() && sim.shifts.len() != sim.times.len() {
        return Err(format!("{} shifts for {} exposure times", sim.shifts.len(), sim.times.len()));
    }
    let (w, h, ch) = (image.width, image.height, image.channels);
    let max = max_code(sim.bits) as f64;
    let frames = sim
        .times
        .iter()
        .enumerate()
        .map(|(f, &t)| {
            let (dx, dy) = sim.shifts.get(f).copied().unwrap_or((0, 0));
            let gain = sim.scale * t;
            let code = |i: usize| -> f64 {
                let (p, c) = (i / 3, i % 3);
                let (x, y) = ((p % w) as i64, (p / w) as i64);
                let sx = (x - dx).clamp(0, w as i64 - 1) as usize;
                let sy = (y - dy).clamp(0, h as i64 - 1) as usize;
                let e = image.data[(sy * w + sx) * ch + c] as f64;
                let mut v = if e > 0.0 { gain * e } else { 0.0 };
                if sim.noise > 0.0 {
                    let sd = sim.noise * (v.min(2.0) / FULL_WELL + (READ_NOISE / FULL_WELL).powi(2)).sqrt();
                    v += sd * normal(sim.seed, f, i);
                }
                (sim.curve.encode(v) * max).round()
            };
            let n = w * h * 3;
            let codes = if sim.bits == 8 {
                Codes::U8((0..n).into_par_iter().map(|i| code(i) as u8).collect())
            } else {
                Codes::U16((0..n).into_par_iter().map(|i| code(i) as u16).collect())
            };
            Frame {
                name: format!("frame{f}_{}", crate::values::brackets::format_time(t)),
                time: t,
                codes,
                covered: None,
            }
        })
        .collect();
    Brackets::new(w, h, sim.bits, frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Image {
        Image::from_fn_rgb(8, 4, |x, y| [x as f32 * 0.1, y as f32 * 0.2 + 0.01, 0.05])
    }

    #[test]
    fn noiseless_codes_are_the_encoded_exposure_and_shifts_fill_from_the_edge() {
        let sim = Simulation {
            times: vec![2.0, 0.5],
            curve: Known::Gamma22,
            bits: 8,
            noise: 0.0,
            seed: 1,
            shifts: vec![(0, 0), (2, -1)],
            scale: 1.0,
        };
        let b = simulate(&ramp(), &sim).unwrap();
        assert_eq!(b.frames[0].time, 0.5, "sorted by time");
        let img = ramp();
        let code = |t: f64, e: f32| (Known::Gamma22.encode(t * e as f64) * 255.0).round() as u16;
        // Frame of 2 s, unshifted: pixel (3, 1).
        assert_eq!(b.frames[1].codes.get((8 + 3) * 3), code(2.0, img.rgb(3, 1)[0]));
        // Frame of 0.5 s shifted by (2, -1): pixel (3, 1) reads (1, 2); pixel (0, 3) reads (0, 3).
        assert_eq!(b.frames[0].codes.get((8 + 3) * 3 + 1), code(0.5, img.rgb(1, 2)[1]));
        assert_eq!(b.frames[0].codes.get((24) * 3 + 1), code(0.5, img.rgb(0, 3)[1]));
    }

    #[test]
    fn noise_is_seeded_and_of_the_stated_size() {
        let flat = Image::from_fn_rgb(64, 64, |_, _| [0.25; 3]);
        let sim = |seed| Simulation {
            times: vec![1.0],
            curve: Known::Gamma22,
            bits: 16,
            noise: 1.0,
            seed,
            shifts: vec![],
            scale: 1.0,
        };
        let a = simulate(&flat, &sim(7)).unwrap();
        assert_eq!(a, simulate(&flat, &sim(7)).unwrap());
        assert_ne!(a, simulate(&flat, &sim(8)).unwrap());
        // Linear values back: mean 0.25, sd sqrt(0.25 / 32768 + (4 / 32768)^2) = 2.766e-3.
        let v: Vec<f64> = (0..a.frames[0].codes.len())
            .map(|i| Known::Gamma22.decode(a.frames[0].codes.get(i) as f64 / 65535.0))
            .collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        assert!((mean - 0.25).abs() < 1e-4, "{mean}");
        assert!((sd / 2.766e-3 - 1.0).abs() < 0.05, "{sd}");
    }
}
