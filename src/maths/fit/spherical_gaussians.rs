//! Fitting spherical Gaussians to a lat-long map, and rendering them back.
//!
//! **Model.** `L_c(d) = sum_k a_kc exp(lambda_k (mu_k . d - 1))`: lobe k has a unit axis
//! `mu_k`, a sharpness `lambda_k` and an RGB amplitude `a_k >= 0` ([`SgLobe`]).
//!
//! **Objective.** Least squares over the texels t of the map, each weighing its solid angle
//! `w_t` (midpoint rule, `latlong::texel_solid_angle`), summed over the three channels:
//! `E = sum_t w_t sum_c (f_tc - L_c(d_t))^2`, reported as the relative RMSE
//! `sqrt(E / sum_t w_t sum_c f_tc^2)` (0 for a black map). A map wider than [`FIT_WIDTH`] or
//! taller than [`FIT_HEIGHT`] is first reduced to `FIT_WIDTH x FIT_HEIGHT`, keeping its
//! integral: by solid-angle-weighted block means when its size is a multiple of that (each
//! fit texel then weighs its block's solid angle, so the midpoint integral is kept exactly),
//! else by the footprint average of `maths::resample::layouts::to_latlong` (1e-3). The fit and its
//! RMSE are on that copy.
//!
//! **Initialisation** (deterministic, `init`): greedy matching pursuit. Each lobe in turn goes
//! to the texel of largest residual luminance not within its predecessors' widths, with the
//! sharpness (on a grid of powers of 2) that best explains the residual there; then NNLS
//! amplitudes for all. `seed` (0: none) jitters each axis by up to a quarter of its lobe's
//! width (SplitMix64).
//!
//! **Rounds** (`iterations` of them), each of steps that never increase E:
//! 1. Axes and sharpnesses, amplitudes fixed: one Levenberg-Marquardt step (Marquardt's
//!    diagonal scaling) on the residuals `sqrt(w_t) (f_tc - L_c(d_t))`, in the parameters
//!    `(u, v, s)` of each lobe: `mu' = normalise(mu + u e1 + v e2)` (`e1, e2` an orthonormal
//!    tangent pair of `mu`) and `lambda' = lambda e^s`. With `G = exp(lambda (mu . d - 1))`,
//!    `dL_c/du = a_c G lambda (e1 . d)`, `dL_c/dv = a_c G lambda (e2 . d)`,
//!    `dL_c/ds = a_c G lambda (mu . d - 1)` (plus the term of `levenberg_marquardt`, which
//!    moves the sharpness at a fixed lobe integral). A step is taken only if it lowers E; otherwise the
//!    damping grows (x4, up to 8 tries), and it shrinks (/3) after a success. Steps are capped
//!    at 0.5 rad and a factor e^2 in sharpness, and `lambda` stays within
//!    [[`MIN_SHARPNESS`], `max_sharpness`], `4 H^2 / pi^2` for a fit map of height H (the lobe's
//!    width `1 / sqrt(lambda)` no less than half a texel: a sharper lobe would fall between the
//!    texel centres it is fitted on).
//! 2. Amplitudes, axes and sharpnesses fixed: per channel, exact non-negative least squares
//!    (`maths::fit::least_squares::nnls`, Lawson-Hanson on the normal equations), kept if E did
//!    not increase.
//! 3. Dead lobes (all amplitudes 0 after NNLS: no gradient, no effect on E) are placed anew by
//!    the pursuit on the current residual, at most 8 a round, and kept if the NNLS amplitudes
//!    that follow lower E.
//!
//! A round that changes nothing ends the fit early: the result is then the same as with more
//! iterations, and the count reported is the rounds that made progress. Lobes are returned most
//! energetic first (luminance of the integral). Every sum runs over fixed blocks of texels,
//! added in order, so the result is bit-identical whatever the number of threads. Kernel values
//! below 1e-12 are left out of the normal equations (not out of E).

use std::f64::consts::PI;
use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use crate::colour::rec709_luminance;
use crate::geometry::latlong;
use crate::maths::fit::least_squares::nnls;
use crate::maths::resample::layouts::{to_latlong, LatLongSource};
use crate::values::sg::value_of;
use crate::values::{Image, SgLobe, SphericalGaussians};

mod init;
mod levenberg_marquardt;

pub use init::initial_lobes;
use levenberg_marquardt::lm_step;

/// Maps wider than this are fitted on a `FIT_WIDTH x FIT_HEIGHT` resampled copy.
pub const FIT_WIDTH: usize = 256;
/// Maps taller than this are fitted on a `FIT_WIDTH x FIT_HEIGHT` resampled copy.
pub const FIT_HEIGHT: usize = 128;
/// The smallest sharpness a fitted lobe takes (nearly constant over the sphere).
pub const MIN_SHARPNESS: f64 = 0.01;
/// Texels per block of the deterministic parallel sums.
const BLOCK: usize = 2048;
/// Dead lobes placed anew per round at most (each costs a pursuit step).
const REVIVE: usize = 8;
/// Kernel values below this are left out of the normal equations.
const ACTIVE: f64 = 1e-12;

/// The texels a fit runs on: directions, solid angles and RGB values.
pub struct Target {
    dirs: Vec<DVec3>,
    weight: Vec<f64>,
    value: Vec<[f64; 3]>,
    pub width: usize,
    pub height: usize,
    /// `sum_t w_t |f_t|^2`.
    norm: f64,
}

impl Target {
    /// The texels of `env` (RGB; a grey image as grey), resampled as the module says.
    pub fn new(env: &Image) -> Target {
        let (w, h) = (env.width, env.height);
        if w <= FIT_WIDTH && h <= FIT_HEIGHT {
            return Target::blocks_of(env, 1, 1);
        }
        if w % FIT_WIDTH == 0 && h % FIT_HEIGHT == 0 {
            return Target::blocks_of(env, w / FIT_WIDTH, h / FIT_HEIGHT);
        }
        Target::blocks_of(&to_latlong(&LatLongSource::new(env), FIT_WIDTH, FIT_HEIGHT), 1, 1)
    }

    /// The `(W / kx) x (H / ky)` target whose texel is the solid-angle-weighted mean of a
    /// `kx x ky` block of `img` and weighs the block's solid angle (so the midpoint integral is
    /// kept exactly, up to rounding).
    fn blocks_of(img: &Image, kx: usize, ky: usize) -> Target {
        let (w, h) = (img.width / kx, img.height / ky);
        let mut t = Target {
            dirs: Vec::with_capacity(w * h),
            weight: Vec::with_capacity(w * h),
            value: Vec::with_capacity(w * h),
            width: w,
            height: h,
            norm: 0.0,
        };
        for y in 0..h {
            for x in 0..w {
                let (mut sum, mut weight) = ([0.0; 3], 0.0);
                for fy in y * ky..(y + 1) * ky {
                    let o = latlong::texel_solid_angle(fy, img.width, img.height);
                    for fx in x * kx..(x + 1) * kx {
                        let v = img.rgb(fx, fy);
                        for c in 0..3 {
                            sum[c] += v[c] as f64 * o;
                        }
                        weight += o;
                    }
                }
                t.dirs.push(DVec3::from(latlong::texel_direction(x, y, w, h)));
                t.weight.push(weight);
                t.value.push(sum.map(|s| s / weight));
            }
        }
        t.norm = t.value.iter().zip(&t.weight).map(|(v, w)| w * v.iter().map(|c| c * c).sum::<f64>()).sum();
        t
    }

    /// `4 H^2 / pi^2`: see the module documentation.
    pub fn max_sharpness(&self) -> f64 {
        4.0 * (self.height as f64 / PI).powi(2)
    }

    /// `f` of each fixed block of texels, in order (run in parallel; deterministic).
    fn blocks<T: Send>(&self, f: impl Fn(Range<usize>) -> T + Sync) -> Vec<T> {
        let n = self.dirs.len();
        (0..n.div_ceil(BLOCK)).into_par_iter().map(|b| f(b * BLOCK..((b + 1) * BLOCK).min(n))).collect()
    }

    /// `E = sum_t w_t sum_c (f_tc - L_c(d_t))^2`.
    pub fn energy(&self, lobes: &[SgLobe]) -> f64 {
        self.blocks(|r| {
            r.map(|t| {
                let model = value_of(lobes, self.dirs[t].into());
                self.weight[t] * (0..3).map(|c| (self.value[t][c] - model[c]).powi(2)).sum::<f64>()
            })
            .sum::<f64>()
        })
        .iter()
        .sum()
    }

    /// `f_t - L(d_t)` per texel.
    fn residual(&self, lobes: &[SgLobe]) -> Vec<[f64; 3]> {
        self.blocks(|r| {
            r.map(|t| {
                let model = value_of(lobes, self.dirs[t].into());
                std::array::from_fn(|c| self.value[t][c] - model[c])
            })
            .collect::<Vec<[f64; 3]>>()
        })
        .concat()
    }

    /// `sqrt(E / sum w |f|^2)`, 0 for a black map.
    pub fn relative_rmse(&self, energy: f64) -> f64 {
        if self.norm > 0.0 {
            (energy / self.norm).sqrt()
        } else {
            0.0
        }
    }

    /// The per-channel NNLS amplitudes for the lobes' axes and sharpnesses: `Q_kl = sum_t w_t
    /// G_k G_l`, `c_ck = sum_t w_t G_k f_tc`.
    fn set_amplitudes(&self, lobes: &mut [SgLobe]) {
        let n = lobes.len();
        let parts = self.blocks(|r| {
            let mut q = vec![0.0; n * n];
            let mut c = vec![0.0; 3 * n];
            let mut g = vec![0.0; n];
            for t in r {
                kernels(lobes, self.dirs[t], &mut g);
                let (w, f) = (self.weight[t], self.value[t]);
                for k in (0..n).filter(|&k| g[k] > ACTIVE) {
                    let wg = w * g[k];
                    for l in (k..n).filter(|&l| g[l] > ACTIVE) {
                        q[k * n + l] += wg * g[l];
                    }
                    for ch in 0..3 {
                        c[ch * n + k] += wg * f[ch];
                    }
                }
            }
            (q, c)
        });
        let (mut q, mut c) = (vec![0.0; n * n], vec![0.0; 3 * n]);
        for (pq, pc) in parts {
            q.iter_mut().zip(pq).for_each(|(a, b)| *a += b);
            c.iter_mut().zip(pc).for_each(|(a, b)| *a += b);
        }
        for k in 0..n {
            for l in 0..k {
                q[k * n + l] = q[l * n + k];
            }
        }
        for ch in 0..3 {
            for (lobe, a) in lobes.iter_mut().zip(nnls(&q, n, &c[ch * n..(ch + 1) * n])) {
                lobe.amplitude[ch] = a;
            }
        }
    }
}

/// `G_k = exp(lambda_k (mu_k . d - 1))` for every lobe, into `g`.
#[inline]
fn kernels(lobes: &[SgLobe], d: DVec3, g: &mut [f64]) {
    for (gk, lobe) in g.iter_mut().zip(lobes) {
        *gk = lobe.kernel(d.into());
    }
}

/// The lobes with the first [`REVIVE`] dead ones (all amplitudes 0, so they have no gradient
/// and do not count in E) placed anew by the pursuit of `init` on the current residual, away from the live
/// lobes, then NNLS amplitudes for all; with their E. `None` when no lobe is dead.
fn revive(t: &Target, lobes: &[SgLobe]) -> Option<(Vec<SgLobe>, f64)> {
    let dead = |l: &SgLobe| l.amplitude == [0.0; 3];
    if !lobes.iter().any(dead) {
        return None;
    }
    let mut residual = t.residual(lobes);
    let mut taken: Vec<SgLobe> = lobes.iter().filter(|l| !dead(l)).cloned().collect();
    let mut out = lobes.to_vec();
    for lobe in out.iter_mut().filter(|l| dead(l)).take(REVIVE) {
        let Some(placed) = init::pursue(t, &mut residual, &taken) else {
            break;
        };
        taken.push(placed.clone());
        *lobe = SgLobe { amplitude: [0.0; 3], ..placed };
    }
    t.set_amplitudes(&mut out);
    let e = t.energy(&out);
    Some((out, e))
}

/// A fit's lobes and how well they fit.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    pub sg: SphericalGaussians,
    /// `sqrt(E / sum w |f|^2)` on the fit map.
    pub relative_rmse: f64,
    /// The rounds that made progress (at most the `iterations` asked for).
    pub iterations: usize,
    /// The fit map's size (the input's, or `FIT_WIDTH x FIT_HEIGHT`).
    pub fit_width: usize,
    pub fit_height: usize,
}

/// Fits `n >= 1` lobes to the finite lat-long map `env` in `iterations` rounds (see the module
/// documentation).
pub fn fit(env: &Image, n: usize, iterations: usize, seed: u64) -> Fit {
    let t = Target::new(env);
    let mut lobes = initial_lobes(&t, n.max(1), seed);
    t.set_amplitudes(&mut lobes);
    let mut energy = t.energy(&lobes);
    let mut damping = 1e-3;
    let mut rounds = 0;
    for _ in 0..iterations {
        let mut progress = false;
        if let Some((moved, e)) = lm_step(&t, &lobes, energy, &mut damping) {
            (lobes, energy, progress) = (moved, e, true);
        }
        let mut refit = lobes.clone();
        t.set_amplitudes(&mut refit);
        let e = t.energy(&refit);
        if e < energy {
            (lobes, energy, progress) = (refit, e, true);
        }
        if let Some((revived, e)) = revive(&t, &lobes) {
            if e < energy {
                (lobes, energy, progress) = (revived, e, true);
            }
        }
        if !progress {
            break;
        }
        rounds += 1;
    }
    let lum = |l: &SgLobe| rec709_luminance(l.integral().map(|v| v as f32));
    lobes.sort_by(|a, b| lum(b).total_cmp(&lum(a)));
    Fit {
        sg: SphericalGaussians { lobes },
        relative_rmse: t.relative_rmse(energy),
        iterations: rounds,
        fit_width: t.width,
        fit_height: t.height,
    }
}

/// The lobes rendered into a `width x height` RGB lat-long map: each texel the model's value
/// at its centre direction (rounded to f32).
pub fn render(sg: &SphericalGaussians, width: usize, height: usize) -> Image {
    let mut out = Image::new(width, height, 3);
    if width == 0 {
        return out;
    }
    out.data.par_chunks_mut(3 * width).enumerate().for_each(|(y, row)| {
        for x in 0..width {
            let v = sg.value(latlong::texel_direction(x, y, width, height));
            for c in 0..3 {
                row[3 * x + c] = v[c] as f32;
            }
        }
    });
    out
}

#[cfg(test)]
mod tests;
