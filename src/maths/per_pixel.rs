//! Per-pixel independent Monte Carlo relighting of a diffuse sphere, as a path tracer does it:
//! every pixel draws its own samples (unlike `RelightSphere`, whose samples are shared by all
//! pixels, so its error is correlated across the image).
//!
//! For a pixel of normal `n` and albedo `a`, `Lo = (a / pi) * (1/N) sum_j F_j`, where `F_j` is
//! one estimate of the irradiance `E(n) = int L(w) max(n.w, 0) dw` (Veach 1997, eq. 2.7, times
//! Lambert's `a / pi`). The strategies ([`PerPixelStrategy`]):
//!
//! - `Environment`: a texel drawn from the map's `Distribution2D` (`sample(u1, u2)`), its centre
//!   direction `d` and its pdf `p` (per steradian, midpoint solid angle):
//!   `F = L(texel) max(n.d, 0) / p`. This is `Sample` + `RelightSphere` per pixel. Expectation:
//!   `sum_{texels, P > 0} L_i max(n.d_i, 0) dOmega_i`, exactly `reference::irradiance_exact`
//!   (when every texel with radiance has a positive probability, as with `BuildCdf` of the
//!   `Luminance` of a non-negative map).
//! - `Cosine`: Malley's method (pbrt-v3 section 13.6.3): a uniform point on the unit disc
//!   (`r = sqrt(u1)`, `phi = 2 pi u2`) lifted to the hemisphere around `n`, pdf `cos / pi`, so
//!   `F = pi L(w)` exactly (the cosine cancels).
//! - `Uniform`: a uniform direction on the sphere (`z = 1 - 2 u1`, `phi = 2 pi u2`; pbrt-v3
//!   section 13.6.1), pdf `1 / (4 pi)`: `F = 4 pi L(w) max(n.w, 0)`.
//! - `Mis`: one environment sample and one cosine sample per count, combined with the balance
//!   heuristic (Veach 1997, section 9.2, multi-sample model, `n_1 = n_2 = 1`):
//!   `F = f(w_e) / (p_e(w_e) + p_c(w_e)) + f(w_c) / (p_e(w_c) + p_c(w_c))`, with
//!   `f(w) = L(w) max(n.w, 0)` and `p_c(w) = max(n.w, 0) / pi`. So `spp` counts are `2 spp`
//!   radiance lookups. The balance heuristic needs both densities at every direction, so here the
//!   environment technique is continuous: the texel drawn from the distribution, then a point
//!   uniform in solid angle inside it (`phi` uniform across the column, `cos theta` uniform
//!   between the row's edges), density `p_e(w) = P(texel) / dOmega_exact`,
//!   `dOmega_exact = (2 pi / W)(cos theta_top - cos theta_bottom)` (NOTES.md, exact per-row solid
//!   angle), evaluated at the texel containing `w`.
//!
//! `L(w)` is the radiance of the texel containing `w` (`latlong::texel_of_direction`). So for
//! `Cosine`, `Uniform` and `Mis` the expectation is the integral of the piecewise-constant map
//! over exact directions, `sum_i L_i int_{texel i} max(n.w, 0) dw`, which differs from the
//! texel-centre sum (`Environment`, `irradiance_exact`) by the midpoint rule only: O(1/H^2)
//! relative (about `(pi / H)^2 / 6`, 1e-4 at H = 128, for a constant map at the poles).
//!
//! Random numbers: each pixel has its own SplitMix64 stream seeded with
//! [`pixel_seed`]`(seed, pixel index)`, so the image is a pure function of `seed`, identical
//! whatever the number of threads (rows run in parallel with rayon).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::data::{Distribution2D, Image};
use crate::geometry::latlong;
use crate::maths::relight::SphereView;
use crate::maths::sequences::{mix64, SplitMix64};

/// How each pixel samples the environment (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PerPixelStrategy {
    /// Texel centres drawn from the map's distribution (light sampling).
    Environment,
    /// Cosine-weighted hemisphere around the normal (BSDF sampling for a diffuse surface).
    Cosine,
    /// Uniform over the sphere.
    Uniform,
    /// One `Environment`-like and one `Cosine` sample per count, balance heuristic.
    Mis,
}

impl PerPixelStrategy {
    /// The names, in declaration order, as written in pipeline files.
    pub const NAMES: &'static [&'static str] = &["Environment", "Cosine", "Uniform", "Mis"];
    pub const ALL: [PerPixelStrategy; 4] =
        [PerPixelStrategy::Environment, PerPixelStrategy::Cosine, PerPixelStrategy::Uniform, PerPixelStrategy::Mis];

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// The strategy called `name` (case-insensitive), or `None`.
    pub fn from_name(name: &str) -> Option<PerPixelStrategy> {
        Self::ALL.iter().copied().find(|s| s.name().eq_ignore_ascii_case(name.trim()))
    }

    /// Whether the strategy draws from the environment's distribution.
    pub fn uses_distribution(self) -> bool {
        matches!(self, PerPixelStrategy::Environment | PerPixelStrategy::Mis)
    }
}

/// The seed of pixel `pixel`'s generator: SplitMix64's finaliser applied to the user seed
/// (with a domain constant, "PERPIXEL" in ASCII) plus the pixel index times the golden-ratio
/// increment, mixed again (Steele, Lea, Flood 2014: distinct inputs give independent-looking
/// streams).
#[inline]
pub fn pixel_seed(seed: u64, pixel: u64) -> u64 {
    mix64(mix64(seed ^ 0x5045_5250_4958_454C).wrapping_add(pixel.wrapping_mul(0x9E37_79B9_7F4A_7C15)))
}

/// Radiance of the texel containing `d`.
#[inline]
fn radiance(env: &Image, d: DVec3) -> [f64; 3] {
    let (x, y) = latlong::texel_of_direction(d.to_array(), env.width, env.height);
    env.rgb(x, y).map(|v| v as f64)
}

/// Malley's method: a cosine-distributed direction around unit `n` (pdf `cos / pi`), in the
/// orthonormal basis (b1, b2, n) of Duff et al., "Building an Orthonormal Basis, Revisited",
/// JCGT 6(1), 2017, listing 3 (glam's `any_orthonormal_pair` is that listing).
#[inline]
pub(crate) fn sample_cosine(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let (s, c) = (2.0 * PI * u2).sin_cos();
    let (lx, ly, lz) = (r * c, r * s, (1.0 - u1).max(0.0).sqrt());
    let (b1, b2) = n.any_orthonormal_pair();
    lx * b1 + ly * b2 + lz * n
}

/// A uniform direction on the unit sphere (pdf `1 / (4 pi)`).
#[inline]
fn sample_uniform(u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u2).sin_cos();
    DVec3::new(r * c, r * s, z)
}

/// Exact solid angle of a texel of row `y`: `(2 pi / W)(cos theta_top - cos theta_bottom)`.
#[inline]
fn exact_texel_solid_angle(y: usize, w: usize, h: usize) -> f64 {
    (2.0 * PI / w as f64) * ((PI * y as f64 / h as f64).cos() - (PI * (y + 1) as f64 / h as f64).cos())
}

/// The continuous environment technique of `Mis`: a texel from `dist`, then a point uniform in
/// solid angle inside it.
#[inline]
fn sample_env_continuous(dist: &Distribution2D, u: [f64; 4]) -> DVec3 {
    let (w, h) = (dist.width, dist.height);
    let (x, y, _) = dist.sample(u[0], u[1]);
    let phi = 2.0 * PI * (x as f64 + u[2]) / w as f64;
    let c0 = (PI * y as f64 / h as f64).cos();
    let c1 = (PI * (y + 1) as f64 / h as f64).cos();
    let ct = c0 + (c1 - c0) * u[3];
    let st = (1.0 - ct * ct).max(0.0).sqrt();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(-st * sp, ct, st * cp)
}

/// Density (per steradian) of [`sample_env_continuous`] at `d`: the probability of the texel
/// containing `d` over its exact solid angle.
#[inline]
fn pdf_env_continuous(dist: &Distribution2D, d: DVec3) -> f64 {
    let (x, y) = latlong::texel_of_direction(d.to_array(), dist.width, dist.height);
    let p = dist.texel_probability(x, y) / exact_texel_solid_angle(y, dist.width, dist.height);
    if p.is_finite() && p > 0.0 {
        p
    } else {
        0.0
    }
}

/// One pixel's irradiance estimate `(1/spp) sum_j F_j` (see the module documentation) at unit
/// normal `n`, drawing uniforms from `rng`. `spp == 0` gives zeros. `dist` must describe a map
/// of `env`'s size when the strategy uses it (unchecked here; [`relight_per_pixel`] checks).
pub fn estimate_irradiance(
    env: &Image,
    dist: &Distribution2D,
    n: [f64; 3],
    strategy: PerPixelStrategy,
    spp: usize,
    rng: &mut SplitMix64,
) -> [f64; 3] {
    let n = DVec3::from(n);
    let mut sum = [0.0f64; 3];
    let mut add = |l: [f64; 3], k: f64| {
        for ch in 0..3 {
            sum[ch] += l[ch] * k;
        }
    };
    for _ in 0..spp {
        match strategy {
            PerPixelStrategy::Environment => {
                let (x, y, pdf) = dist.sample(rng.next_f64(), rng.next_f64());
                if pdf > 0.0 {
                    let d = DVec3::from(latlong::texel_direction(x, y, env.width, env.height));
                    let c = n.dot(d).max(0.0);
                    add(env.rgb(x, y).map(|v| v as f64), c / pdf);
                }
            }
            PerPixelStrategy::Cosine => {
                let w = sample_cosine(n, rng.next_f64(), rng.next_f64());
                // f / p = L cos / (cos / pi) = pi L.
                add(radiance(env, w), PI);
            }
            PerPixelStrategy::Uniform => {
                let w = sample_uniform(rng.next_f64(), rng.next_f64());
                add(radiance(env, w), 4.0 * PI * n.dot(w).max(0.0));
            }
            PerPixelStrategy::Mis => {
                let u = [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()];
                let we = sample_env_continuous(dist, u);
                let wc = sample_cosine(n, rng.next_f64(), rng.next_f64());
                for w in [we, wc] {
                    let c = n.dot(w).max(0.0);
                    if c > 0.0 {
                        // Balance heuristic: w_i f / p_i = f / (p_e + p_c).
                        let denom = pdf_env_continuous(dist, w) + c / PI;
                        add(radiance(env, w), c / denom);
                    }
                }
            }
        }
    }
    if spp == 0 {
        return [0.0; 3];
    }
    sum.map(|s| s / spp as f64)
}

/// Renders the diffuse sphere with per-pixel independent samples: `Lo = (albedo / pi) *`
/// [`estimate_irradiance`] with `spp` counts at every pixel of `view`'s disc (normals from
/// [`SphereView::normal_at`]), 0 off the disc; pixel `i = py * size + px` draws from
/// `SplitMix64::new(pixel_seed(seed, i))`. Rows in parallel; the result does not depend on the
/// number of threads.
///
/// Panics if the strategy uses `dist` and `dist` is not over a map of `env`'s size (the
/// operator checks this first).
pub fn relight_per_pixel(
    env: &Image,
    dist: &Distribution2D,
    view: &SphereView,
    albedo: [f64; 3],
    strategy: PerPixelStrategy,
    spp: usize,
    seed: u64,
) -> Image {
    if strategy.uses_distribution() {
        assert!(
            dist.width == env.width && dist.height == env.height,
            "distribution over {}x{} for a {}x{} map",
            dist.width,
            dist.height,
            env.width,
            env.height
        );
    }
    let size = view.size;
    let mut image = Image::new(size, size, 3);
    if size == 0 || env.width == 0 || env.height == 0 {
        return image;
    }
    let scale = albedo.map(|a| a / PI);
    image.data.par_chunks_mut(size * 3).enumerate().for_each(|(py, row)| {
        for px in 0..size {
            let Some(n) = view.normal_at(px, py) else { continue };
            let mut rng = SplitMix64::new(pixel_seed(seed, (py * size + px) as u64));
            let e = estimate_irradiance(env, dist, n, strategy, spp, &mut rng);
            for ch in 0..3 {
                row[px * 3 + ch] = (scale[ch] * e[ch]) as f32;
            }
        }
    });
    image
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::reference::irradiance_exact;
    use crate::maths::test_maps::{luminance_distribution, replicate};

    #[test]
    fn names_and_seeds() {
        for s in PerPixelStrategy::ALL {
            assert_eq!(PerPixelStrategy::from_name(s.name()), Some(s));
            assert_eq!(PerPixelStrategy::from_name(&s.name().to_uppercase()), Some(s));
        }
        assert_eq!(PerPixelStrategy::from_name("nope"), None);
        assert_ne!(pixel_seed(1, 0), pixel_seed(1, 1));
        assert_ne!(pixel_seed(1, 0), pixel_seed(2, 0));
    }

    #[test]
    fn samplers_are_on_the_sphere_and_in_the_right_texel() {
        let mut rng = SplitMix64::new(5);
        let env = Image::from_fn_rgb(16, 8, |x, y| [(x + 16 * y) as f32 + 1.0, 1.0, 1.0]);
        let dist = luminance_distribution(&env);
        for _ in 0..10_000 {
            let n = sample_uniform(rng.next_f64(), rng.next_f64());
            assert!((n.dot(n) - 1.0).abs() < 1e-12);
            let (b1, b2) = n.any_orthonormal_pair();
            assert!(b1.dot(n).abs() < 1e-12 && b2.dot(n).abs() < 1e-12 && b1.dot(b2).abs() < 1e-12);
            let w = sample_cosine(n, rng.next_f64(), rng.next_f64());
            assert!((w.dot(w) - 1.0).abs() < 1e-12 && w.dot(n) >= -1e-12);
            let u = [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()];
            let we = sample_env_continuous(&dist, u);
            assert!((we.dot(we) - 1.0).abs() < 1e-12);
            assert!(pdf_env_continuous(&dist, we) > 0.0);
        }
        // The exact texel solid angles sum to 4 pi.
        let total: f64 = (0..8).map(|y| 16.0 * exact_texel_solid_angle(y, 16, 8)).sum();
        assert!((total - 4.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn constant_map_gives_albedo_for_every_strategy() {
        let env = Image::from_fn_rgb(64, 32, |_, _| [1.0, 1.0, 1.0]);
        let dist = luminance_distribution(&env);
        let albedo = [0.8, 0.5, 0.3];
        let size = 96;
        let view = SphereView::new(size, [0.2, 0.4, 0.9]);
        for s in PerPixelStrategy::ALL {
            let img = relight_per_pixel(&env, &dist, &view, albedo, s, 32, 7);
            let mut sum = [0.0f64; 3];
            let mut count = 0usize;
            for py in 0..size {
                for px in 0..size {
                    if view.normal_at(px, py).is_some() {
                        for (s, &v) in sum.iter_mut().zip(img.pixel(px, py)) {
                            *s += v as f64;
                        }
                        count += 1;
                    } else {
                        assert_eq!(img.pixel(px, py), &[0.0f32; 3][..]);
                    }
                }
            }
            for ch in 0..3 {
                let mean = sum[ch] / count as f64;
                eprintln!("{s:?} constant map: mean / albedo = {:.5} (channel {ch})", mean / albedo[ch]);
                assert!((mean / albedo[ch] - 1.0).abs() < 0.01, "{s:?} ch{ch}: {mean}");
            }
            if s == PerPixelStrategy::Cosine {
                // pi L per sample: every pixel is exact.
                for py in 0..size {
                    for px in 0..size {
                        if view.normal_at(px, py).is_some() {
                            assert!((img.pixel(px, py)[0] as f64 - 0.8).abs() < 1e-6);
                        }
                    }
                }
            }
        }
    }

    fn small_random_map() -> Image {
        let mut rng = SplitMix64::new(2024);
        let mut data = Vec::new();
        for i in 0..16 * 8 {
            let px = if i == 37 {
                [40.0, 30.0, 20.0] // a bright texel in the upper hemisphere
            } else {
                [0.1 + rng.next_f64() as f32, 0.1 + 0.5 * rng.next_f64() as f32, 0.1 + 2.0 * rng.next_f64() as f32]
            };
            data.extend_from_slice(&px);
        }
        Image::from_vec(16, 8, 3, data)
    }

    /// The mean over many seeds of a pixel matches the exact expectation within 3 standard
    /// errors: `irradiance_exact` for `Environment`; for the other strategies the integral over
    /// exact texel areas, computed as `irradiance_exact` of the map with each texel replicated
    /// 32 x 32 (the midpoint rule's O(1/H^2) error divided by 1024).
    #[test]
    fn unbiased_for_every_strategy() {
        let env = small_random_map();
        let dist = luminance_distribution(&env);
        let fine = replicate(&env, 32);
        let size = 9;
        let view = SphereView::new(size, [0.3, 0.6, 0.7]);
        let pixels = [(4usize, 4usize), (2, 6)];
        let seeds = 4000u64;
        let spp = 4;
        for &(px, py) in &pixels {
            let n = view.normal_at(px, py).unwrap();
            let centres = irradiance_exact(&env, &[n])[0];
            let areas = irradiance_exact(&fine, &[n])[0];
            let sum3 = |e: [f64; 3]| (e[0] + e[1] + e[2]) / PI;
            eprintln!(
                "pixel ({px},{py}): texel-centre sum {:.6}, exact-area integral {:.6} (midpoint rule: {:+.2e} relative)",
                sum3(centres),
                sum3(areas),
                sum3(centres) / sum3(areas) - 1.0
            );
            for s in PerPixelStrategy::ALL {
                let want = if s == PerPixelStrategy::Environment { sum3(centres) } else { sum3(areas) };
                let mut m = 0.0f64;
                let mut m2 = 0.0f64;
                for seed in 0..seeds {
                    let img = relight_per_pixel(&env, &dist, &view, [1.0; 3], s, spp, seed);
                    let p = img.pixel(px, py);
                    let v = (p[0] + p[1] + p[2]) as f64;
                    m += v;
                    m2 += v * v;
                }
                let mean = m / seeds as f64;
                let var = (m2 / seeds as f64 - mean * mean) * seeds as f64 / (seeds - 1) as f64;
                let se = (var / seeds as f64).sqrt();
                let z = (mean - want) / se;
                eprintln!("  {s:?}: mean {mean:.6}, want {want:.6}, standard error {se:.2e}, z = {z:+.2}");
                assert!(z.abs() < 3.0, "{s:?} pixel ({px},{py}): z = {z}");
                assert!(se < 0.02 * want, "{s:?}: the test is too weak (se {se})");
            }
        }
    }

    #[test]
    fn identical_whatever_the_thread_count() {
        let env = small_random_map();
        let dist = luminance_distribution(&env);
        let view = SphereView::new(37, [0.1, -0.3, 0.9]);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for s in PerPixelStrategy::ALL {
            let a = one.install(|| relight_per_pixel(&env, &dist, &view, [0.9, 0.7, 0.5], s, 5, 99));
            let b = two.install(|| relight_per_pixel(&env, &dist, &view, [0.9, 0.7, 0.5], s, 5, 99));
            assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits()), "{s:?}");
            assert!(a.data.iter().any(|&v| v > 0.0));
            let c = two.install(|| relight_per_pixel(&env, &dist, &view, [0.9, 0.7, 0.5], s, 5, 100));
            assert_ne!(a.data, c.data, "{s:?} ignores its seed");
        }
    }

    #[test]
    fn zero_spp_and_empty_view() {
        let env = small_random_map();
        let dist = luminance_distribution(&env);
        let view = SphereView::new(8, [0.0, 0.0, 1.0]);
        let img = relight_per_pixel(&env, &dist, &view, [1.0; 3], PerPixelStrategy::Mis, 0, 1);
        assert!(img.data.iter().all(|&v| v == 0.0));
        let img = relight_per_pixel(
            &env,
            &dist,
            &SphereView::new(0, [0.0, 0.0, 1.0]),
            [1.0; 3],
            PerPixelStrategy::Cosine,
            4,
            1,
        );
        assert!(img.data.is_empty());
    }

    /// Timing: `cargo test --release per_pixel_timing -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn per_pixel_timing() {
        let sky = crate::formats::builtin::builtin("sky").unwrap();
        let dist = luminance_distribution(&sky);
        let view = SphereView::new(256, latlong::direction_deg(90.0, 90.0));
        for s in PerPixelStrategy::ALL {
            let t = std::time::Instant::now();
            std::hint::black_box(relight_per_pixel(&sky, &dist, &view, [0.8; 3], s, 64, 1));
            eprintln!("per-pixel {s:?} 256x256 x 64 spp on sky 512x256: {:.3} s", t.elapsed().as_secs_f64());
        }
    }
}
