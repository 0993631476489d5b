//! Per-pixel independent Monte Carlo relighting of a diffuse sphere, as a path tracer does it:
//! every pixel draws its own samples (unlike `RelightSphere`, whose samples are shared by all
//! pixels, so its error is correlated across the image).
//!
//! For a pixel of normal `n` and albedo `a`, `Lo = (a / pi) * (1/N) sum_j F_j`, where `F_j` is
//! one estimate of the irradiance `E(n) = int L(w) max(n.w, 0) dw` (Veach 1997, eq. 2.7, times
//! Lambert's `a / pi`). The strategies ([`PerPixelStrategy`]):
//!
//! - `Environment`: a texel drawn from the map's `Distribution2D` (by the chosen
//!   [`PerPixelWarp`]: `sample(u1, u2)`'s inversion, or the hierarchical warp), its centre
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
//!   heuristic (Veach 1997, section 9.2, multi-sample model, `n_1 = n_2 = 1`; the power
//!   heuristic on request, [`PerPixelOptions::heuristic`]):
//!   `F = f(w_e) / (p_e(w_e) + p_c(w_e)) + f(w_c) / (p_e(w_c) + p_c(w_c))`, with
//!   `f(w) = L(w) max(n.w, 0)` and `p_c(w) = max(n.w, 0) / pi`. So `spp` counts are `2 spp`
//!   radiance lookups. The balance heuristic needs both densities at every direction, so here the
//!   environment technique is continuous: the texel drawn from the distribution, then a point
//!   uniform in solid angle inside it (`phi` uniform across the column, `cos theta` uniform
//!   between the row's edges, placed by where `(u1, u2)` fell inside the texel's CDF intervals:
//!   [`GuidedDistribution::finish_continuous`], or inside its last mip-map choice:
//!   [`HierarchicalWarp::finish`]), density `p_e(w) = P(texel) / dOmega_exact`,
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
//! whatever the number of threads (rows run in parallel with rayon). With
//! [`PerPixelSequence::Sobol`] the stream seeds the pixel's Owen scrambles instead (same
//! expectation, lower variance; Mitsuba's `ldsampler` does the same).
//!
//! The environment technique's texel comes from one of two warps ([`PerPixelWarp`]), the same
//! probabilities either way: inversion of the marginal and conditional CDFs (the default, the
//! fastest) or a descent of the probabilities' mip-map ([`HierarchicalWarp`], Mitsuba's
//! envmap sampler), which carries Sobol points' stratification over the map's area better.
//!
//! Speed (issue 14; docs/src/benchmarks/relighting.md has the numbers against Mitsuba 3's LLVM variant). A sample
//! costs a few table reads and no call to libm:
//! - the texel is drawn by inversion through guide tables ([`GuidedDistribution`]; Chen and
//!   Asau 1974) rather than two binary searches: the same texel as `Distribution2D::sample` for
//!   the same uniforms, O(1) expected reads. Not Walker's alias table: inversion keeps a Sobol
//!   point's stratification across the map, which the alias method scrambles;
//! - texel-centre directions, edges and solid angles are precomputed per row and column
//!   ([`LatLongGrid`]); a direction is mapped to its texel by polynomial guesses corrected
//!   exactly against the edge tables, and `sin`/`cos` of an angle in turns by a polynomial;
//! - each texel's radiance and technique density sit in one 16-byte record, and samples run in
//!   batches of 16: first every sample's texel, then the records. The texel search itself runs
//!   in stages across the batch with a prefetch between them (the row's guide entry, then the
//!   CDF where the search starts, then the records: [`GuidedDistribution::start`]), so the
//!   batch's cache misses overlap instead of each sample waiting for its own; for `Mis` the
//!   cosine technique's arithmetic runs between the stages (its directions while the guide
//!   entries arrive, its texel lookups while the CDF entries do);
//! - the batch's arithmetic runs as structure-of-arrays loops over its 16 lanes, compiled twice:
//!   for AVX-512 (8 f64 lanes, run at the `crate::cpu` level `avx512`) and for the baseline (the
//!   one scalar fallback, run at the levels below). The loops are the uniforms
//!   ([`SplitMix64::peek`] makes a counter-based generator's draws independent of each other),
//!   the cosine directions with their texel guesses, the environment directions, and `Mis`'s
//!   weights and sums; the table reads between them stay scalar. Both compilations perform the
//!   same IEEE operations in the same order (Rust never contracts `a * b + c` into a fused
//!   multiply-add), so an image has the same bits on any x86_64 processor: a test compares the
//!   two for every loop. The hierarchical warp's 2x2 steps use AVX-512 intrinsics (gathers) the
//!   same way. The single-thread times before and after are in docs/src/benchmarks/relighting.md ("Per-pixel
//!   sampling against Mitsuba 3").
//!
//! Not done: the guided search and the texel corrections stay scalar (their loops end at a
//! data-dependent step; with gathers they would need a masked retry loop).
//!
//! The parts: `lanes` (the batch's lane loops and their two compilations), `uniforms` (a pixel's
//! uniforms, [`PerPixelSequence`]), `scene` (the per-map tables and one pixel's estimate from
//! them); here, the choices and the renderer.
//!
//! [`GuidedDistribution`]: crate::maths::sampling::guide_table::GuidedDistribution
//! [`GuidedDistribution::finish_continuous`]: crate::maths::sampling::guide_table::GuidedDistribution::finish_continuous
//! [`GuidedDistribution::start`]: crate::maths::sampling::guide_table::GuidedDistribution::start
//! [`HierarchicalWarp`]: crate::maths::sampling::hierarchical_warp::HierarchicalWarp
//! [`HierarchicalWarp::finish`]: crate::maths::sampling::hierarchical_warp::HierarchicalWarp::finish
//! [`LatLongGrid`]: crate::geometry::latlong_grid::LatLongGrid
//! [`SplitMix64::peek`]: crate::maths::sampling::sequences::SplitMix64::peek

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::maths::render::relight::SphereView;
use crate::maths::sampling::mis::Heuristic;
use crate::maths::sampling::sequences::{mix64, GOLDEN_GAMMA};
use crate::values::{Distribution2D, Image};

mod lanes;
mod scene;
mod uniforms;

pub(crate) use lanes::sample_cosine;
use scene::Scene;
use uniforms::PixelUniforms;

crate::choice! {
    /// How each pixel samples the environment (see the module documentation).
    pub enum PerPixelStrategy {
        /// Texel centres drawn from the map's distribution (light sampling).
        Environment,
        /// Cosine-weighted hemisphere around the normal (BSDF sampling for a diffuse surface).
        Cosine,
        /// Uniform over the sphere.
        Uniform,
        /// One `Environment`-like and one `Cosine` sample per count, MIS.
        Mis,
    }
}

impl PerPixelStrategy {
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
    mix64(mix64(seed ^ 0x5045_5250_4958_454C).wrapping_add(pixel.wrapping_mul(GOLDEN_GAMMA)))
}

crate::choice! {
    /// Where a pixel's uniforms come from.
    pub enum PerPixelSequence {
        /// Independent uniforms from the pixel's SplitMix64 stream.
        Random,
        /// Per pixel, Owen-scrambled 2D Sobol points (Burley, "Practical Hash-based Owen
        /// Scrambling", JCGT 9(4), 2020): each 2D request of a sample (the environment texel, the
        /// point inside it, the cosine direction) is its own Sobol sequence, scrambled with seeds
        /// from the pixel's stream, its index shuffled by a nested uniform scramble (Burley's
        /// padding), so the pairs are independent of each other and every pixel is an independent
        /// randomised-QMC estimate. With a power-of-two `spp` each pair is a (0, m, 2)-net. The 32
        /// Sobol bits are completed to 53 with random low bits so every texel of positive
        /// probability stays reachable. This is the analogue of Mitsuba's `ldsampler`.
        Sobol,
    }
}

crate::choice! {
    /// How the environment technique maps a 2D uniform to a texel (and the point inside it).
    /// Both draw every texel with the distribution's probability, so the estimator's
    /// expectation and, with independent uniforms, its whole distribution are the same; they
    /// differ in how well they carry a low-discrepancy point set's stratification over to the
    /// map (docs/src/benchmarks/relighting.md measures both with `sequence: Sobol`).
    pub enum PerPixelWarp {
        /// Rows by inverting the marginal CDF with `u1`, then the column by inverting the row's
        /// conditional CDF with `u2`, through guide tables (pbrt's `Distribution2D`): O(1)
        /// reads per sample, the fastest.
        Inversion,
        /// Descending a mip-map of the texel probabilities (Mitsuba 3's `Hierarchical2D`,
        /// [`HierarchicalWarp`]): each quadrant of the unit square goes to a compact part of
        /// the map, so Sobol points stay evenly spread over it (on Grace, half the error of
        /// `Inversion` for `Environment` at 1024 spp); one step per mip level, so slower.
        ///
        /// [`HierarchicalWarp`]: crate::maths::sampling::hierarchical_warp::HierarchicalWarp
        Hierarchical,
    }
}

/// Panics unless `dist` is over a map of `env`'s size (the operators check this first, with a
/// friendly error; the renderers index `env` with the texels `dist` draws).
pub(crate) fn assert_distribution_of(dist: &Distribution2D, env: &Image) {
    assert!(
        dist.width() == env.width && dist.height() == env.height,
        "distribution over {}x{} for a {}x{} map",
        dist.width(),
        dist.height(),
        env.width,
        env.height
    );
}

/// How [`relight_per_pixel_with`] samples each pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PerPixelOptions {
    pub strategy: PerPixelStrategy,
    pub sequence: PerPixelSequence,
    /// `Mis` only: the balance heuristic (the module documentation's formula) or the power
    /// heuristic (exponent 2, Veach 1997 section 9.2.2; Mitsuba's `direct` integrator), whose
    /// sample weights are `f p_own / (p_e^2 + p_c^2)`.
    pub heuristic: Heuristic,
    /// `Environment` and `Mis` only: how a uniform pair becomes a texel.
    pub warp: PerPixelWarp,
    pub spp: usize,
    pub seed: u64,
}

/// [`relight_per_pixel_with`] with independent random uniforms ([`PerPixelSequence::Random`])
/// and, for `Mis`, the balance heuristic.
pub fn relight_per_pixel(
    env: &Image,
    dist: &Distribution2D,
    view: &SphereView,
    albedo: [f64; 3],
    strategy: PerPixelStrategy,
    spp: usize,
    seed: u64,
) -> Image {
    let options = PerPixelOptions {
        strategy,
        sequence: PerPixelSequence::Random,
        heuristic: Heuristic::Balance,
        warp: PerPixelWarp::Inversion,
        spp,
        seed,
    };
    relight_per_pixel_with(env, dist, view, albedo, &options)
}

/// Renders the diffuse sphere with per-pixel independent samples: `Lo = (albedo / pi) *` the
/// pixel's irradiance estimate with `spp` counts at every pixel of `view`'s disc (normals from
/// [`SphereView::normal_at`]), 0 off the disc; pixel `i = py * size + px` draws its uniforms
/// from `sequence` seeded with [`pixel_seed`]`(seed, i)`. Rows in parallel; the result does not
/// depend on the number of threads.
///
/// Speed (see docs/src/benchmarks/relighting.md): the texel is drawn through guide tables
/// ([`GuidedDistribution`], the same texel as `Distribution2D::sample`) or, with
/// [`PerPixelWarp::Hierarchical`], by the mip-map descent ([`HierarchicalWarp`]); texel directions,
/// solid angles and edges come from a [`LatLongGrid`], and directions are mapped to texels
/// without libm calls, so a sample costs a few table reads and no trigonometry.
///
/// Panics if the strategy uses `dist` and `dist` is not over a map of `env`'s size (the
/// operator checks this first).
///
/// [`GuidedDistribution`]: crate::maths::sampling::guide_table::GuidedDistribution
/// [`HierarchicalWarp`]: crate::maths::sampling::hierarchical_warp::HierarchicalWarp
/// [`LatLongGrid`]: crate::geometry::latlong_grid::LatLongGrid
pub fn relight_per_pixel_with(
    env: &Image,
    dist: &Distribution2D,
    view: &SphereView,
    albedo: [f64; 3],
    options: &PerPixelOptions,
) -> Image {
    let renderer = PerPixelRenderer::new(env, dist, options.strategy, options.sequence, options.warp);
    renderer.render(view, albedo, options.heuristic, options.spp, options.seed)
}

/// The per-map half of [`relight_per_pixel_with`]: the texel records and the environment
/// technique's sampler, built once and then shared by any
/// number of renders of that map, as a renderer loads its scene once. The benchmark times
/// [`Self::render`] alone, as Mitsuba's peer times `mi.render` after loading the scene.
pub struct PerPixelRenderer<'a> {
    scene: Scene<'a>,
    strategy: PerPixelStrategy,
    sequence: PerPixelSequence,
}

impl<'a> PerPixelRenderer<'a> {
    /// Panics if the strategy uses `dist` and `dist` is not over a map of `env`'s size (the
    /// operator checks this first).
    pub fn new(
        env: &'a Image,
        dist: &'a Distribution2D,
        strategy: PerPixelStrategy,
        sequence: PerPixelSequence,
        warp: PerPixelWarp,
    ) -> PerPixelRenderer<'a> {
        if strategy.uses_distribution() {
            assert_distribution_of(dist, env);
        }
        PerPixelRenderer { scene: Scene::new(env, dist, strategy, warp), strategy, sequence }
    }

    /// [`relight_per_pixel_with`] with this renderer's strategy, sequence and warp.
    pub fn render(&self, view: &SphereView, albedo: [f64; 3], heuristic: Heuristic, spp: usize, seed: u64) -> Image {
        let (strategy, sequence, scene) = (self.strategy, self.sequence, &self.scene);
        let size = view.size;
        let mut image = Image::new(size, size, 3);
        if size == 0 || scene.env.width == 0 || scene.env.height == 0 {
            return image;
        }
        let scale = albedo.map(|a| a / PI);
        image.data.par_chunks_mut(size * 3).enumerate().for_each(|(py, row)| {
            for px in 0..size {
                let Some(n) = view.normal_at(px, py) else { continue };
                let mut uniforms = PixelUniforms::new(sequence, pixel_seed(seed, (py * size + px) as u64));
                let e = scene.estimate_irradiance(DVec3::from(n), strategy, heuristic, spp, &mut uniforms);
                for ch in 0..3 {
                    row[px * 3 + ch] = (scale[ch] * e[ch]) as f32;
                }
            }
        });
        image
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::render::reference::irradiance_exact;
    use crate::maths::sampling::sequences::SplitMix64;
    use crate::maths::test_maps::{luminance_distribution, replicate};

    #[test]
    fn names_and_seeds() {
        for s in PerPixelStrategy::ALL {
            assert_eq!(PerPixelStrategy::from_name(s.name()), Some(s));
            assert_eq!(PerPixelStrategy::from_name_ignore_case(&s.name().to_uppercase()), Some(s));
        }
        assert_eq!(PerPixelStrategy::from_name("nope"), None);
        assert_ne!(pixel_seed(1, 0), pixel_seed(1, 1));
        assert_ne!(pixel_seed(1, 0), pixel_seed(2, 0));
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
            let inversion = PerPixelWarp::Inversion;
            let mut configurations: Vec<(PerPixelStrategy, PerPixelSequence, Heuristic, PerPixelWarp)> =
                PerPixelStrategy::ALL
                    .into_iter()
                    .flat_map(|s| PerPixelSequence::ALL.map(|q| (s, q, Heuristic::Balance, inversion)))
                    .collect();
            configurations
                .extend(PerPixelSequence::ALL.map(|q| (PerPixelStrategy::Mis, q, Heuristic::Power, inversion)));
            // The hierarchical warp draws the same texels with the same probabilities.
            let hierarchical = PerPixelWarp::Hierarchical;
            configurations.extend([
                (PerPixelStrategy::Environment, PerPixelSequence::Sobol, Heuristic::Balance, hierarchical),
                (PerPixelStrategy::Mis, PerPixelSequence::Random, Heuristic::Balance, hierarchical),
                (PerPixelStrategy::Mis, PerPixelSequence::Sobol, Heuristic::Power, hierarchical),
            ]);
            for (s, q, h, warp) in configurations {
                let want = if s == PerPixelStrategy::Environment { sum3(centres) } else { sum3(areas) };
                let mut m = 0.0f64;
                let mut m2 = 0.0f64;
                for seed in 0..seeds {
                    let options = PerPixelOptions { strategy: s, sequence: q, heuristic: h, warp, spp, seed };
                    let img = relight_per_pixel_with(&env, &dist, &view, [1.0; 3], &options);
                    let p = img.pixel(px, py);
                    let v = (p[0] + p[1] + p[2]) as f64;
                    m += v;
                    m2 += v * v;
                }
                let mean = m / seeds as f64;
                let var = (m2 / seeds as f64 - mean * mean) * seeds as f64 / (seeds - 1) as f64;
                let se = (var / seeds as f64).sqrt();
                let z = (mean - want) / se;
                eprintln!(
                    "  {s:?} {q:?} {h:?} {warp:?}: mean {mean:.6}, want {want:.6}, standard error {se:.2e}, z = {z:+.2}"
                );
                assert!(z.abs() < 3.5, "{s:?} {q:?} {h:?} {warp:?} pixel ({px},{py}): z = {z}");
                assert!(se < 0.02 * want, "{s:?}: the test is too weak (se {se})");
            }
        }
    }

    /// The same bits whatever the thread count; and since the batch functions give the scalar
    /// lanes' bits at every level (`lanes`' and `uniforms`' tests), whatever the machine.
    #[test]
    fn identical_whatever_the_thread_count() {
        let env = small_random_map();
        let dist = luminance_distribution(&env);
        let view = SphereView::new(37, [0.1, -0.3, 0.9]);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for s in PerPixelStrategy::ALL {
            let variants = PerPixelSequence::ALL
                .into_iter()
                .flat_map(|q| Heuristic::ALL.map(|h| (q, h)))
                .flat_map(|(q, h)| PerPixelWarp::ALL.map(|warp| (q, h, warp)));
            for (q, h, warp) in variants {
                let render = |seed| {
                    let options = PerPixelOptions { strategy: s, sequence: q, heuristic: h, warp, spp: 5, seed };
                    relight_per_pixel_with(&env, &dist, &view, [0.9, 0.7, 0.5], &options)
                };
                let a = one.install(|| render(99));
                let b = two.install(|| render(99));
                assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits()), "{s:?} {q:?} {h:?}");
                assert!(a.data.iter().any(|&v| v > 0.0));
                let c = two.install(|| render(100));
                assert_ne!(a.data, c.data, "{s:?} {q:?} {h:?} ignores its seed");
            }
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
}
