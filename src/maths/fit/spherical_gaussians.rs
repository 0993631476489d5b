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
//! **What a texel holds.** A map fitted at its own size is taken as point values: `L_c(d_t)` is
//! the model at the texel's centre (what `SgToLatLong` renders). A texel of the reduced copy
//! holds the map's mean over it, so there `L_c(d_t)` stands for the lobes' means over the
//! texel, `sum_k a_kc M_t(G_k)` (`texel_mean`: Gauss-Legendre, within 1e-7 of each lobe's
//! peak), and the derivatives below for their means likewise. Point values there would fit
//! sharp lobes low: a lobe of sharpness 100 / 300 / 1000 stored as texel means at 1024 x 512
//! came back 4.8e-3 / 8.4e-3 / 4.1e-2 too narrow and dim (issue 39; now within 1e-4).
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
//!    [[`MIN_SHARPNESS`], `max_sharpness`]. For a map fitted at its own size H that is
//!    `4 H^2 / pi^2` (the lobe's width `1 / sqrt(lambda)` no less than half a texel: a sharper
//!    lobe would fall between the texel centres it is fitted on). For a reduced map, whose
//!    texels are fitted with the lobes' means, a lobe narrower than that still puts its energy
//!    in the texels around its axis, so the cap is `4 H_src^2 / pi^2` for the height `H_src`
//!    of the map given (half of its texel, so that `SgToLatLong` at its size resolves the
//!    lobe), but at most [`MEAN_CAP_FACTOR`] = 3 times the fit map's (a width of 0.29 fit
//!    texel). Narrower still, a lobe's texel means hardly change as its axis moves inside a
//!    texel, and fits stall: on `builtin:sky` (512 x 256) 12 lobes reach a relative RMSE of
//!    0.017 with the factor 3, 0.037 with 2 and 0.074 with 4 (0.048 when reduced texels were
//!    fitted with point values), and on the park map 0.080, 0.175 and 0.037 (0.258; a factor of
//!    1 gives 0.42, the sun being narrower than a fit texel). The factor is that measurement's,
//!    not a derivation. The pursuit's sharpness grid stops at the fit map's own cap.
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
mod texel_mean;

pub use init::initial_lobes;
use levenberg_marquardt::lm_step;
use texel_mean::TexelMeans;

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
/// The sharpness cap of a reduced map is at most this times the fit map's (module docs).
pub const MEAN_CAP_FACTOR: f64 = 3.0;

/// The texels a fit runs on: directions, solid angles and RGB values.
pub struct Target {
    dirs: Vec<DVec3>,
    weight: Vec<f64>,
    value: Vec<[f64; 3]>,
    pub width: usize,
    pub height: usize,
    /// `sum_t w_t |f_t|^2`.
    norm: f64,
    /// For a reduced map, whose texels hold means: the lobes' means over the texels
    /// (`texel_mean`); `None`: the lobes' values at the texel centres.
    means: Option<TexelMeans>,
    /// The largest sharpness (module documentation).
    cap: f64,
}

impl Target {
    /// The texels of `env` (RGB; a grey image as grey), resampled as the module says.
    pub fn new(env: &Image) -> Target {
        let (w, h) = (env.width, env.height);
        if w <= FIT_WIDTH && h <= FIT_HEIGHT {
            return Target::blocks_of(env, 1, 1);
        }
        let mut t = if w % FIT_WIDTH == 0 && h % FIT_HEIGHT == 0 {
            Target::blocks_of(env, w / FIT_WIDTH, h / FIT_HEIGHT)
        } else {
            Target::blocks_of(&to_latlong(&LatLongSource::new(env), FIT_WIDTH, FIT_HEIGHT), 1, 1)
        };
        t.means = Some(TexelMeans::new(t.width, t.height));
        t.cap = (4.0 * (h as f64 / PI).powi(2)).min(MEAN_CAP_FACTOR * t.point_cap());
        t
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
            means: None,
            cap: 4.0 * (h as f64 / PI).powi(2),
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

    /// The largest sharpness of a fitted lobe: see the module documentation.
    pub fn max_sharpness(&self) -> f64 {
        self.cap
    }

    /// `4 H^2 / pi^2` for the fit map's height H: the sharpest lobe its texel centres resolve
    /// (the pursuit's grid stops there).
    pub fn point_cap(&self) -> f64 {
        4.0 * (self.height as f64 / PI).powi(2)
    }

    /// `f` of each fixed block of texels, in order (run in parallel; deterministic).
    fn blocks<T: Send>(&self, f: impl Fn(Range<usize>) -> T + Sync) -> Vec<T> {
        let n = self.dirs.len();
        (0..n.div_ceil(BLOCK)).into_par_iter().map(|b| f(b * BLOCK..((b + 1) * BLOCK).min(n))).collect()
    }

    /// The model's value at texel `t`: `L(d_t)`, or for a reduced map the lobes' means over
    /// the texel (`sum_k a_k M_t(G_k)`).
    #[inline]
    fn model(&self, lobes: &[SgLobe], t: usize) -> [f64; 3] {
        match &self.means {
            None => value_of(lobes, self.dirs[t].into()),
            Some(m) => lobes.iter().fold([0.0; 3], |s, l| {
                let g = m.kernel(t, self.dirs[t], l);
                [s[0] + l.amplitude[0] * g, s[1] + l.amplitude[1] * g, s[2] + l.amplitude[2] * g]
            }),
        }
    }

    /// Each lobe's kernel at texel `t` (`G_k(d_t)`, or `M_t(G_k)` for a reduced map), into `g`.
    #[inline]
    fn kernels_at(&self, lobes: &[SgLobe], t: usize, g: &mut [f64]) {
        match &self.means {
            None => kernels(lobes, self.dirs[t], g),
            Some(m) => g.iter_mut().zip(lobes).for_each(|(gk, l)| *gk = m.kernel(t, self.dirs[t], l)),
        }
    }

    /// `E = sum_t w_t sum_c (f_tc - L_c(d_t))^2` (`L_c(d_t)`: the model at texel `t`).
    pub fn energy(&self, lobes: &[SgLobe]) -> f64 {
        self.blocks(|r| {
            r.map(|t| {
                let model = self.model(lobes, t);
                self.weight[t] * (0..3).map(|c| (self.value[t][c] - model[c]).powi(2)).sum::<f64>()
            })
            .sum::<f64>()
        })
        .iter()
        .sum()
    }

    /// `f_t - L(d_t)` per texel (the model at texel `t`).
    fn residual(&self, lobes: &[SgLobe]) -> Vec<[f64; 3]> {
        self.blocks(|r| {
            r.map(|t| {
                let model = self.model(lobes, t);
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
                self.kernels_at(lobes, t, &mut g);
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
