//! A glossy sphere under an environment map: the modified Phong BRDF, rendered per pixel by
//! Monte Carlo with three strategies, and its exact texel sum.
//!
//! **BRDF** (modified Phong: E. P. Lafortune, Y. D. Willems, "Using the Modified Phong
//! Reflectance Model for Physically Based Rendering", KU Leuven report CW 197, 1994, eq. 3 and
//! 6), per RGB channel, with `k_d` the diffuse and `k_s` the specular reflectance:
//!
//! ```text
//! f(w) = k_d / pi + k_s (s + 2) / (2 pi) cos^s(alpha)      (cos(alpha) > 0; else k_d / pi)
//! ```
//!
//! where `alpha` is the angle between the light direction `w` and the mirror direction
//! `r = 2 (n.v) n - v` of the view `v` about the normal `n` ([`phong::mirror`]). The reflected
//! radiance is `Lo = int L(w) f(w) max(n.w, 0) dw` (the cosine and the hemisphere check: light
//! from below the surface adds nothing). When `r = n` (the pixel at the centre of the sphere,
//! seen along its normal), `int (s + 2) / (2 pi) cos^(s+1)(theta) dw = 1` exactly, so a
//! constant environment of radiance 1 gives `Lo = k_d + k_s` there; elsewhere the lobe is cut by
//! the horizon and `Lo < k_d + k_s`.
//!
//! **Strategies** ([`GlossyStrategy`]), each an unbiased estimator of the same integral of the
//! piecewise-constant map (radiance of the texel containing `w`, `latlong::texel_of_direction`):
//!
//! - `Environment`: a texel drawn from the map's `Distribution2D`, then a point uniform in solid
//!   angle inside it (the continuous technique of `PerPixelSphere`'s `Mis`); density
//!   `p_e(w) = P(texel) / dOmega_exact(texel)`.
//! - `Brdf`: a lobe chosen with probability proportional to the channel means of `k_d` and
//!   `k_s` (`q_d = mean(k_d) / (mean(k_d) + mean(k_s))`), then either a cosine-weighted direction
//!   around `n` (Malley's method) or the seed's Phong lobe sampler around `r`
//!   ([`phong::sample_lobe`], density `(s + 1) / (2 pi) cos^s(alpha)`); the estimator divides by
//!   the mixture density `p_b(w) = q_d max(n.w, 0) / pi + (1 - q_d) (s + 1) / (2 pi)
//!   cos^s(alpha)` (one-sample mixture, so either lobe's samples see both densities). Lobe
//!   directions below the surface count as samples of value 0.
//! - `Mis`: multiple importance sampling (E. Veach, *Robust Monte Carlo Methods for Light
//!   Transport Simulation*, PhD thesis, Stanford 1997, section 9.2.2, the multi-sample model):
//!   of the `spp` samples, `n_e = ceil(spp / 2)` from the environment and `n_b = floor(spp / 2)`
//!   from the BRDF (so `spp` counts radiance lookups for every strategy and costs compare at
//!   equal `spp`), `F = sum_i (1 / n_i) sum_j w_i(X_ij) f L cos / p_i(X_ij)`, with the
//!   [`Heuristic`] `Balance` `w_i = n_i p_i / sum_k n_k p_k` or `Power` (beta = 2)
//!   `w_i = (n_i p_i)^2 / sum_k (n_k p_k)^2` (Veach, eq. 9.13 and 9.14).
//!
//! **Reference** ([`reference_glossy_sphere`]): the midpoint sum over texel centres,
//! `Lo = sum_i L_i f(d_i) max(n.d_i, 0) dOmega_i` with the midpoint solid angles of
//! `geometry::latlong`, in f64 (relative rounding below 1e-10). The Monte Carlo strategies
//! converge to the integral over exact texel areas instead; the two differ by the midpoint rule,
//! O(h^2) relative with `h = pi / H` the texel's angle, and the more so the narrower the lobe
//! (the error grows like `s h^2`): compare on a map whose texels are small against the lobe
//! (the tests replicate every texel of a coarse map 8 x 8, which keeps the same
//! piecewise-constant function and divides the midpoint error by 64).
//!
//! **Random numbers**: each pixel has its own SplitMix64 stream seeded with
//! [`crate::maths::render::per_pixel::pixel_seed`]`(seed, pixel index)`; rows run in parallel with rayon and the image
//! is a pure function of `seed`, bit for bit, whatever the number of threads.
//!
//! Files: this one holds the BRDF and the Monte Carlo strategies; `reference` the exact texel
//! sum and the point light; `tests` the tests of both.

mod reference;
#[cfg(test)]
mod tests;

pub use reference::{add_light, reference_glossy_sphere, PackedTexels};

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::latlong;
use crate::maths::brdf::phong;
use crate::maths::render::per_pixel::{assert_distribution_of, pixel_seed, sample_cosine};
use crate::maths::render::relight::SphereView;
pub use crate::maths::sampling::mis::Heuristic;
use crate::maths::sampling::sequences::SplitMix64;
use crate::values::{Distribution2D, Image};

crate::choice! {
    /// How each pixel samples its directions (see the module documentation).
    pub enum GlossyStrategy {
        /// Directions from the environment's distribution (light sampling).
        Environment,
        /// Directions from the BRDF: cosine lobe or Phong lobe, chosen by reflectance.
        Brdf,
        /// Half of each, combined by multiple importance sampling.
        Mis,
    }
}

/// The modified Phong BRDF of the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlossyBrdf {
    /// `k_d` per channel.
    pub diffuse: [f64; 3],
    /// `k_s` per channel.
    pub specular: [f64; 3],
    /// The Phong exponent `s >= 0`.
    pub exponent: f64,
}

impl GlossyBrdf {
    /// The probability `q_d` of sampling the diffuse lobe: the channel mean of `k_d` over that
    /// of `k_d + k_s` (`None` when both are zero: the BRDF is 0).
    pub fn diffuse_probability(&self) -> Option<f64> {
        let d = self.diffuse.iter().sum::<f64>().max(0.0);
        let s = self.specular.iter().sum::<f64>().max(0.0);
        if d + s > 0.0 {
            Some(d / (d + s))
        } else {
            None
        }
    }

    /// `(s + 2) / (2 pi) cos^s(alpha)` for unit `r` and `w` (0 for cos(alpha) <= 0, s > 0), from
    /// the sampler's density `(s + 1) / (2 pi) cos^s(alpha)` ([`phong::lobe_pdf`], stable for
    /// large s).
    #[inline]
    fn specular_lobe(&self, r: DVec3, w: DVec3) -> f64 {
        let s = self.exponent;
        phong::lobe_pdf(r.to_array(), w.to_array(), s) * ((s + 2.0) / (s + 1.0))
    }

    /// `f(w) max(n.w, 0)` per channel.
    #[inline]
    fn eval_cos(&self, n: DVec3, r: DVec3, w: DVec3) -> [f64; 3] {
        let c = n.dot(w);
        if !(c > 0.0) {
            return [0.0; 3];
        }
        let lobe = self.specular_lobe(r, w);
        std::array::from_fn(|ch| (self.diffuse[ch] / PI + self.specular[ch] * lobe) * c)
    }

    /// A direction from the mixture: the diffuse lobe when `u[0] < q_d`, else the Phong lobe.
    #[inline]
    fn sample(&self, q_d: f64, n: DVec3, r: DVec3, u: [f64; 3]) -> DVec3 {
        if u[0] < q_d {
            sample_cosine(n, u[1], u[2])
        } else {
            DVec3::from(phong::sample_lobe(r.to_array(), self.exponent, u[1], u[2]).0)
        }
    }
}

/// The environment technique's sample: a texel from `dist`, then a point uniform in solid angle
/// inside it (`phi` uniform across the column, `cos theta` uniform between the row's edges).
/// Returns the direction and its texel (the texel drawn, so no lookup is needed).
#[inline]
fn sample_env(dist: &Distribution2D, u: [f64; 4]) -> (DVec3, (usize, usize)) {
    let (w, h) = (dist.width(), dist.height());
    let (x, y, _) = dist.sample(u[0], u[1]);
    let phi = 2.0 * PI * (x as f64 + u[2]) / w as f64;
    let c0 = (PI * y as f64 / h as f64).cos();
    let c1 = (PI * (y + 1) as f64 / h as f64).cos();
    let ct = c0 + (c1 - c0) * u[3];
    let st = (1.0 - ct * ct).max(0.0).sqrt();
    let (sp, cp) = phi.sin_cos();
    (DVec3::new(-st * sp, ct, st * cp), (x, y))
}

/// The environment technique's density at any direction of texel (x, y):
/// `P(texel) / dOmega_exact`, `dOmega_exact = (2 pi / W)(cos theta_top - cos theta_bottom)`.
#[inline]
fn env_pdf(dist: &Distribution2D, x: usize, y: usize) -> f64 {
    let (w, h) = (dist.width(), dist.height());
    let d_omega = (2.0 * PI / w as f64) * ((PI * y as f64 / h as f64).cos() - (PI * (y + 1) as f64 / h as f64).cos());
    let p = dist.texel_probability(x, y) / d_omega;
    if p.is_finite() && p > 0.0 {
        p
    } else {
        0.0
    }
}

/// One pixel's estimate of `Lo` (per channel) at unit normal `n` seen from unit `v`, with `spp`
/// radiance lookups (see the module documentation). `spp == 0` or a zero BRDF gives zeros.
#[allow(clippy::too_many_arguments)]
pub fn estimate_radiance(
    env: &Image,
    dist: &Distribution2D,
    brdf: &GlossyBrdf,
    n: [f64; 3],
    v: [f64; 3],
    strategy: GlossyStrategy,
    heuristic: Heuristic,
    spp: usize,
    rng: &mut SplitMix64,
) -> [f64; 3] {
    let Some(q_d) = brdf.diffuse_probability() else { return [0.0; 3] };
    if spp == 0 {
        return [0.0; 3];
    }
    let n = DVec3::from(n);
    let r = DVec3::from(phong::mirror(v, n.to_array()));
    let s = brdf.exponent;
    let spec_norm = (s.max(0.0) + 2.0) / (s.max(0.0) + 1.0);
    let diffuse = brdf.diffuse.map(|k| k / PI);
    // For a unit direction `w` in texel (x, y): `L f cos` per channel, `p_e` and `p_b`
    // (`None` below the surface, where the integrand is 0).
    let eval = |w: DVec3, (x, y): (usize, usize)| -> Option<([f64; 3], f64, f64)> {
        let c = n.dot(w);
        if !(c > 0.0) {
            return None;
        }
        let lobe = phong::lobe_pdf_unit(r, w, s);
        let l = env.rgb(x, y);
        let lfc = std::array::from_fn(|ch| l[ch] as f64 * (diffuse[ch] + brdf.specular[ch] * lobe * spec_norm) * c);
        let p_b = q_d * c / PI + (1.0 - q_d) * lobe;
        Some((lfc, env_pdf(dist, x, y), p_b))
    };
    let texel = |w: DVec3| latlong::texel_of_direction(w.to_array(), env.width, env.height);
    let brdf_sample = |rng: &mut SplitMix64| brdf.sample(q_d, n, r, [rng.next_f64(), rng.next_f64(), rng.next_f64()]);
    let env_sample =
        |rng: &mut SplitMix64| sample_env(dist, [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()]);
    let mut sum = [0.0f64; 3];
    let mut add = |lfc: [f64; 3], k: f64| {
        if k > 0.0 && k.is_finite() {
            for ch in 0..3 {
                sum[ch] += lfc[ch] * k;
            }
        }
    };
    match strategy {
        GlossyStrategy::Environment => {
            for _ in 0..spp {
                let (w, t) = env_sample(rng);
                if let Some((lfc, p_e, _)) = eval(w, t) {
                    add(lfc, 1.0 / (spp as f64 * p_e));
                }
            }
        }
        GlossyStrategy::Brdf => {
            for _ in 0..spp {
                let w = brdf_sample(rng);
                if let Some((lfc, _, p_b)) = eval(w, texel(w)) {
                    add(lfc, 1.0 / (spp as f64 * p_b));
                }
            }
        }
        GlossyStrategy::Mis => {
            let n_e = spp.div_ceil(2) as f64;
            let n_b = (spp / 2) as f64;
            for _ in 0..spp.div_ceil(2) {
                let (w, t) = env_sample(rng);
                if let Some((lfc, p_e, p_b)) = eval(w, t) {
                    add(lfc, heuristic.weight(n_e * p_e, n_b * p_b) / (n_e * p_e));
                }
            }
            for _ in 0..spp / 2 {
                let w = brdf_sample(rng);
                if let Some((lfc, p_e, p_b)) = eval(w, texel(w)) {
                    add(lfc, heuristic.weight(n_b * p_b, n_e * p_e) / (n_b * p_b));
                }
            }
        }
    }
    sum
}

/// Renders the glossy sphere: [`estimate_radiance`] with `spp` lookups at every pixel of
/// `view`'s disc (normals from [`SphereView::normal_at`], view direction
/// [`SphereView::view_dir`]: the camera is orthographic), 0 off the disc; pixel
/// `i = py * size + px` draws from `SplitMix64::new(pixel_seed(seed, i))`. Rows in parallel; the
/// result does not depend on the number of threads.
///
/// Panics if `dist` is not over a map of `env`'s size (the operator checks this first).
#[allow(clippy::too_many_arguments)]
pub fn glossy_sphere(
    env: &Image,
    dist: &Distribution2D,
    view: &SphereView,
    brdf: &GlossyBrdf,
    strategy: GlossyStrategy,
    heuristic: Heuristic,
    spp: usize,
    seed: u64,
) -> Image {
    assert_distribution_of(dist, env);
    let size = view.size;
    let mut image = Image::new(size, size, 3);
    if size == 0 || env.width == 0 || env.height == 0 {
        return image;
    }
    let v = view.view_dir();
    image.data.par_chunks_mut(size * 3).enumerate().for_each(|(py, row)| {
        for px in 0..size {
            let Some(n) = view.normal_at(px, py) else { continue };
            let mut rng = SplitMix64::new(pixel_seed(seed, (py * size + px) as u64));
            let lo = estimate_radiance(env, dist, brdf, n, v, strategy, heuristic, spp, &mut rng);
            for ch in 0..3 {
                row[px * 3 + ch] = lo[ch] as f32;
            }
        }
    });
    image
}
