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
//! Speed (issue 14; BENCHMARKS.md has the numbers against Mitsuba 3's LLVM variant). A sample
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
//!   for AVX-512 (8 f64 lanes, chosen at run time when the processor has AVX-512F and DQ) and
//!   for the baseline (the one scalar fallback). The loops are the uniforms
//!   ([`SplitMix64::peek`] makes a counter-based generator's draws independent of each other),
//!   the cosine directions with their texel guesses, the environment directions, and `Mis`'s
//!   weights and sums; the table reads between them stay scalar. Both compilations perform the
//!   same IEEE operations in the same order (Rust never contracts `a * b + c` into a fused
//!   multiply-add), so an image has the same bits on any x86_64 processor: a test compares the
//!   two for every loop. The hierarchical warp's 2x2 steps use AVX-512 intrinsics (gathers) the
//!   same way. Single thread `Mis Power` at 1024 spp on Grace: 0.97 s scalar, 0.47 s now.
//!
//! Not done: the guided search and the texel corrections stay scalar (their loops end at a
//! data-dependent step; with gathers they would need a masked retry loop).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::cpu;
use crate::geometry::latlong_grid::{point_in_band, sincos_turns, LatLongGrid};
use crate::maths::guide_table::{GuidedDistribution, GuidedDraw};
use crate::maths::hierarchical_warp::{HierarchicalWarp, WarpDraw};
use crate::maths::mis::Heuristic;
use crate::maths::prefetch;
use crate::maths::relight::SphereView;
use crate::maths::sequences::{
    bits_to_unit, mix64, nested_uniform_scramble, sobol_2d_bits, unit_f64, SplitMix64, GOLDEN_GAMMA,
};
use crate::values::{Distribution2D, Image};

/// Which compilation of the batch lane loops runs (see [`avx512_batch!`]): both give the same bits.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BatchKernel {
    /// Compiled for AVX-512F and DQ; asked for without them (or off x86_64), `Baseline` runs.
    Avx512,
    /// The baseline compilation, every processor.
    Baseline,
}

impl cpu::Kernels for BatchKernel {
    const FASTEST_FIRST: &'static [BatchKernel] = &[BatchKernel::Avx512, BatchKernel::Baseline];

    fn needs(self) -> cpu::Features {
        match self {
            BatchKernel::Avx512 => cpu::Features { avx512: true, ..cpu::Features::BASELINE },
            BatchKernel::Baseline => cpu::Features::BASELINE,
        }
    }
}

/// Declares `$batch(kernel, args)`: the lane loop `$lanes(args)` compiled a second time, as
/// `$avx512`, for AVX-512F and DQ, and called for [`BatchKernel::Avx512`] when the processor has
/// them ([`cpu::has_avx512`], checked on every call: a cached load); otherwise, and off x86_64,
/// the baseline compilation. The two run the same IEEE operations in the same order, so they
/// give the same bits.
macro_rules! avx512_batch {
    ($(#[$doc:meta])* fn $batch:ident / $avx512:ident = $lanes:ident($($arg:ident: $ty:ty),* $(,)?)) => {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512dq")]
        unsafe fn $avx512($($arg: $ty),*) {
            $lanes($($arg),*)
        }

        $(#[$doc])*
        #[inline(always)]
        fn $batch(kernel: BatchKernel, $($arg: $ty),*) {
            #[cfg(target_arch = "x86_64")]
            if kernel == BatchKernel::Avx512 && cpu::has_avx512() {
                // SAFETY: the processor has AVX-512F and DQ (checked just above).
                return unsafe { $avx512($($arg),*) };
            }
            let _ = kernel;
            $lanes($($arg),*)
        }
    };
}

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

/// Malley's method: a cosine-distributed direction around unit `n` (pdf `cos / pi`), in the
/// orthonormal basis (b1, b2, n) of Duff et al., "Building an Orthonormal Basis, Revisited",
/// JCGT 6(1), 2017, listing 3 (glam's `any_orthonormal_pair` is that listing).
#[inline]
pub(crate) fn sample_cosine(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let (b1, b2) = n.any_orthonormal_pair();
    cosine_in_basis(n, b1, b2, u1, u2)
}

/// [`sample_cosine`] with the basis computed once per pixel and no libm trigonometry
/// ([`sincos_turns`]). The polar map of the disc (`r = sqrt(u1)`, `phi = 2 pi u2`), not Shirley
/// and Chiu's concentric map (Mitsuba's): tried, it gave the same per-pixel Sobol errors on Grace
/// and the sky (within 1%) in the same time, so the simpler map stays.
#[inline(always)]
fn cosine_in_basis(n: DVec3, b1: DVec3, b2: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let (s, c) = sincos_turns(u2);
    let (lx, ly, lz) = (r * c, r * s, (1.0 - u1).max(0.0).sqrt());
    lx * b1 + ly * b2 + lz * n
}

/// A batch's cosine directions, structure of arrays: `u[0][i], u[1][i]` in, `out[axis][i]` out,
/// [`cosine_in_basis`] lane by lane, and the guesses of the texels containing them
/// ([`LatLongGrid::texel_guess`]) into `guess[k][i]`. Written as a plain loop so that the
/// compiler vectorises it when it may use AVX-512 ([`cosine_batch`]): the polynomial sine,
/// cosine and arc guesses and the square roots are most of a `Mis` sample's arithmetic. The
/// same operations either way (Rust never fuses a multiply and an add on its own), so the same
/// bits: a test compares them.
#[inline(always)]
fn cosine_batch_lanes(batch: &CosineBatch, out: &mut [[f64; BATCH]; 3], guess: &mut [[f64; BATCH]; 2]) {
    let [n, b1, b2] = batch.basis;
    for i in 0..BATCH {
        let d = cosine_in_basis(n, b1, b2, batch.u[0][i], batch.u[1][i]);
        [out[0][i], out[1][i], out[2][i]] = d.to_array();
        [guess[0][i], guess[1][i]] = batch.grid.texel_guess(d.to_array());
    }
}

/// The inputs of [`cosine_batch_lanes`]: the pixel's basis `[n, b1, b2]`, the uniforms and the
/// map's grid.
struct CosineBatch<'g> {
    basis: [DVec3; 3],
    u: [[f64; BATCH]; 2],
    grid: &'g LatLongGrid,
}

avx512_batch! {
    /// [`cosine_batch_lanes`], with AVX-512 when asked and the processor has it.
    fn cosine_batch / cosine_batch_avx512 = cosine_batch_lanes(
        batch: &CosineBatch,
        out: &mut [[f64; BATCH]; 3],
        guess: &mut [[f64; BATCH]; 2]
    )
}

/// A batch's environment directions, [`point_in_band`] lane by lane: `band[0..3][i]` are the
/// azimuth in turns and the row's edge cosines, `v[i]` the fraction between them; into
/// `out[axis][i]`. Vectorised as [`cosine_batch_lanes`] (the table reads stay outside).
#[inline(always)]
fn band_point_lanes(band: &[[f64; BATCH]; 3], v: &[f64; BATCH], out: &mut [[f64; BATCH]; 3]) {
    for i in 0..BATCH {
        [out[0][i], out[1][i], out[2][i]] = point_in_band(band[0][i], band[1][i], band[2][i], v[i]);
    }
}

avx512_batch! {
    /// [`band_point_lanes`], with AVX-512 when asked and the processor has it.
    fn band_point_batch / band_point_avx512 = band_point_lanes(
        band: &[[f64; BATCH]; 3],
        v: &[f64; BATCH],
        out: &mut [[f64; BATCH]; 3]
    )
}

/// A `Mis` batch's stage 2 inputs, structure of arrays, technique `t` (0 environment, 1
/// cosine) and lane `i`: the direction `dir[t][axis][i]`, the record's radiance
/// `radiance[t][channel][i]` and environment density `pdf[t][i]`.
struct MisBatch {
    normal: DVec3,
    heuristic: Heuristic,
    dir: [[[f64; BATCH]; 3]; 2],
    radiance: [[[f32; BATCH]; 3]; 2],
    pdf: [[f32; BATCH]; 2],
}

/// Adds each lane's two weighted samples (environment, then cosine) to its sum `sums[ch][i]`,
/// for the lanes `i < count`: `f / p` weighted by the heuristic, with `c = max(n.w, 0)`,
/// `p_c = c / pi` and `p_e` the record's density:
/// - balance: `w_t f / p_t = f / (p_e + p_c)`, and `c / (p_e + c / pi) = pi c / (pi p_e + c)`
///   (one division);
/// - power: `w_t f / p_t = f p_t / (p_e^2 + p_c^2)`.
///
/// A sample with `c = 0` adds 0 (its weight's `0 / 0` is not used). A plain loop over lanes
/// (see [`cosine_batch_lanes`]).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane i of several arrays
fn mis_lanes(batch: &MisBatch, count: usize, sums: &mut [[f64; BATCH]; 3]) {
    let n = batch.normal;
    for i in 0..BATCH {
        for t in 0..2 {
            let d = DVec3::new(batch.dir[t][0][i], batch.dir[t][1][i], batch.dir[t][2][i]);
            let c = n.dot(d).max(0.0);
            let pe = batch.pdf[t][i] as f64;
            let weight = match batch.heuristic {
                Heuristic::Balance => PI * c / (PI * pe + c),
                Heuristic::Power => {
                    let pc = c / PI;
                    c * if t == 0 { pe } else { pc } / (pe * pe + pc * pc)
                }
            };
            let used = i < count && c > 0.0;
            for ch in 0..3 {
                sums[ch][i] += if used { batch.radiance[t][ch][i] as f64 * weight } else { 0.0 };
            }
        }
    }
}

avx512_batch! {
    /// [`mis_lanes`], with AVX-512 when asked and the processor has it.
    fn mis_batch / mis_avx512 = mis_lanes(batch: &MisBatch, count: usize, sums: &mut [[f64; BATCH]; 3])
}

/// A uniform direction on the unit sphere (pdf `1 / (4 pi)`).
#[inline]
fn sample_uniform(u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sincos_turns(u2);
    DVec3::new(r * c, r * s, z)
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
    /// map (BENCHMARKS.md measures both with `sequence: Sobol`).
    pub enum PerPixelWarp {
        /// Rows by inverting the marginal CDF with `u1`, then the column by inverting the row's
        /// conditional CDF with `u2`, through guide tables (pbrt's `Distribution2D`): O(1)
        /// reads per sample, the fastest.
        Inversion,
        /// Descending a mip-map of the texel probabilities (Mitsuba 3's `Hierarchical2D`,
        /// [`HierarchicalWarp`]): each quadrant of the unit square goes to a compact part of
        /// the map, so Sobol points stay evenly spread over it (on Grace, half the error of
        /// `Inversion` for `Environment` at 1024 spp); one step per mip level, so slower.
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

/// One pixel's source of 2D uniforms (see [`PerPixelSequence`]).
struct PixelUniforms {
    rng: SplitMix64,
    /// Per 2D request k: (index shuffle seed, x scramble seed, y scramble seed); `None` for
    /// `Random`.
    sobol: Option<[[u32; 3]; 2]>,
}

impl PixelUniforms {
    fn new(sequence: PerPixelSequence, seed: u64) -> PixelUniforms {
        let mut rng = SplitMix64::new(seed);
        let sobol = match sequence {
            PerPixelSequence::Random => None,
            PerPixelSequence::Sobol => {
                let mut seeds = [[0u32; 3]; 2];
                for s in seeds.iter_mut().flatten() {
                    *s = (rng.next_u64() >> 32) as u32;
                }
                Some(seeds)
            }
        };
        PixelUniforms { rng, sobol }
    }

    /// The uniforms of samples `start + i` for `i < count` (at most [`BATCH`]), requests
    /// `k < requests` (1 or 2) of each, into `out[2k][i], out[2k + 1][i]`. Request 0 chooses the
    /// texel (and, for `Mis`, the point inside it): 53-bit uniforms, so that every texel of
    /// positive probability can be drawn; request 1 chooses a direction around the normal, where
    /// 32 bits (2.3e-10) are far finer than any texel, so `Random` takes both from one 64-bit
    /// draw. Each sample draws its requests in order, then the next sample, and the pixel's
    /// generator advances by the `count` samples' draws. Lanes past `count` are filled too (a
    /// fixed-length loop vectorises; they are unused). `kernel` as in [`avx512_batch!`].
    #[inline(always)]
    fn batch(&mut self, kernel: BatchKernel, start: usize, count: usize, requests: usize, out: &mut [[f64; BATCH]; 4]) {
        let lanes = UniformLanes { rng: &self.rng, sobol: self.sobol, start, requests };
        uniform_batch(kernel, &lanes, out);
        self.rng.skip((count * lanes.draws_per_sample()) as u64);
    }
}

/// What [`uniform_lanes`] computes from: the pixel's generator (read, not advanced), its Sobol
/// scrambles and the batch's first sample and request count.
struct UniformLanes<'r> {
    rng: &'r SplitMix64,
    sobol: Option<[[u32; 3]; 2]>,
    start: usize,
    requests: usize,
}

impl UniformLanes<'_> {
    /// 64-bit draws per sample: `Random` takes two for request 0 and one for request 1, `Sobol`
    /// one per request (the low bits below its 32 Sobol bits).
    #[inline(always)]
    fn draws_per_sample(&self) -> usize {
        match self.sobol {
            None => 2 + (self.requests > 1) as usize,
            Some(_) => self.requests,
        }
    }
}

/// [`PixelUniforms::batch`]'s values, lane by lane, as a plain loop (see [`cosine_batch_lanes`]).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane i of several arrays
fn uniform_lanes(lanes: &UniformLanes, out: &mut [[f64; BATCH]; 4]) {
    let per_sample = lanes.draws_per_sample();
    let both = lanes.requests > 1;
    match lanes.sobol {
        None => {
            for i in 0..BATCH {
                let r = (i * per_sample) as u64;
                out[0][i] = unit_f64(lanes.rng.peek(r));
                out[1][i] = unit_f64(lanes.rng.peek(r + 1));
                if both {
                    let v = lanes.rng.peek(r + 2);
                    out[2][i] = bits_to_unit((v >> 32) as u32);
                    out[3][i] = bits_to_unit(v as u32);
                }
            }
        }
        Some(seeds) => {
            let fill = |bits: u32, low21: u64| (((bits as u64) << 21) | low21) as f64 * (1.0 / (1u64 << 53) as f64);
            for i in 0..BATCH {
                let j = (lanes.start + i) as u32;
                for (k, &[shuffle, sx, sy]) in seeds.iter().enumerate().take(lanes.requests) {
                    let [x, y] = sobol_2d_bits(nested_uniform_scramble(j, shuffle));
                    let low = lanes.rng.peek((i * per_sample + k) as u64);
                    out[2 * k][i] = fill(nested_uniform_scramble(x, sx), low & 0x1F_FFFF);
                    out[2 * k + 1][i] = fill(nested_uniform_scramble(y, sy), (low >> 21) & 0x1F_FFFF);
                }
            }
        }
    }
}

avx512_batch! {
    /// [`uniform_lanes`], with AVX-512 when asked and the processor has it.
    fn uniform_batch / uniform_lanes_avx512 = uniform_lanes(lanes: &UniformLanes, out: &mut [[f64; BATCH]; 4])
}

/// What one texel offers a sample that lands in it: its radiance and the density (per
/// steradian) of the strategy's environment technique there. 16 bytes, so one cache line holds
/// four and a sample's texel costs one memory read. The density is stored as f32: a relative
/// rounding of 6e-8, which biases the estimate by at most that much (the f64 arithmetic around
/// it is unchanged).
#[derive(Clone, Copy, Debug, Default)]
struct TexelRecord {
    radiance: [f32; 3],
    pdf: f32,
}

/// Samples processed per batch: the texels of a batch are found first and read second, so the
/// processor has a batch's worth of independent memory reads in flight instead of one chain per
/// sample (the tables exceed the L2 cache on a 1024x512 map).
const BATCH: usize = 16;

/// What every pixel reads: the lat-long tables, the per-texel records and, when the strategy
/// draws from the distribution, its texel sampler (guide tables or the hierarchical warp).
struct Scene<'a> {
    env: &'a Image,
    grid: LatLongGrid,
    /// Empty for the strategies that need no density (`Cosine`, `Uniform`: they read `env`).
    records: Vec<TexelRecord>,
    /// How the environment technique draws its texel; `None` for `Cosine` and `Uniform`.
    texels: Option<TexelSampler<'a>>,
    /// Which compilation of the batch functions runs (the fastest the processor has).
    kernel: BatchKernel,
}

/// The environment technique's texel sampler, one per [`PerPixelWarp`].
enum TexelSampler<'a> {
    Guided(GuidedDistribution<'a>),
    Hierarchical(HierarchicalWarp),
}

/// A batch's texel draws between the stages of a [`TexelSampler`].
struct BatchDraws {
    guided: [GuidedDraw; BATCH],
    warp: [WarpDraw; BATCH],
}

impl TexelSampler<'_> {
    /// Stage 1 of sample `i`'s draw (prefetches what stage 2 reads).
    #[inline(always)]
    fn start(&self, draws: &mut BatchDraws, i: usize, u1: f64, u2: f64) {
        match self {
            TexelSampler::Guided(g) => draws.guided[i] = g.start(u1, u2),
            TexelSampler::Hierarchical(h) => draws.warp[i] = h.start(u1, u2),
        }
    }

    /// Stage 2 for the batch's first `count` draws.
    #[inline(always)]
    fn resume(&self, draws: &mut BatchDraws, count: usize) {
        match self {
            TexelSampler::Guided(g) => draws.guided[..count].iter_mut().for_each(|d| g.resume(d)),
            TexelSampler::Hierarchical(h) => h.descend(&mut draws.warp[..count]),
        }
    }

    /// Draw `i`'s texel and where it fell inside, `(x, y, rx, ry)` (uniform given the texel).
    #[inline(always)]
    fn finish(&self, draws: &BatchDraws, i: usize) -> (usize, usize, f64, f64) {
        match self {
            TexelSampler::Guided(g) => g.finish_continuous(&draws.guided[i]),
            TexelSampler::Hierarchical(h) => h.finish(&draws.warp[i]),
        }
    }

    /// Draw `i`'s texel alone (for the discrete `Environment` technique).
    #[inline(always)]
    fn finish_texel(&self, draws: &BatchDraws, i: usize) -> (usize, usize) {
        match self {
            TexelSampler::Guided(g) => g.finish(&draws.guided[i]),
            TexelSampler::Hierarchical(h) => {
                let (x, y, _, _) = h.finish(&draws.warp[i]);
                (x, y)
            }
        }
    }
}

impl<'a> Scene<'a> {
    /// Records hold the radiance and, for `Environment`, the midpoint density
    /// `P(texel) / dOmega_mid` (the pdf of `Distribution2D::sample`), for `Mis` the continuous
    /// technique's `P(texel) / dOmega_exact`; 0 where that is not a positive finite number.
    /// Built only for the strategies that draw from the distribution.
    fn new(env: &'a Image, dist: &'a Distribution2D, strategy: PerPixelStrategy, warp: PerPixelWarp) -> Scene<'a> {
        let (w, h) = (env.width, env.height);
        let grid = LatLongGrid::new(w, h);
        let uses_distribution = strategy.uses_distribution();
        let mut records = vec![TexelRecord::default(); if uses_distribution { w * h } else { 0 }];
        records.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
            let solid_angle = match strategy {
                PerPixelStrategy::Environment => grid.midpoint_solid_angle(y),
                _ => grid.exact_solid_angle(y),
            };
            for (x, r) in row.iter_mut().enumerate() {
                let p = dist.texel_probability(x, y) / solid_angle;
                *r =
                    TexelRecord { radiance: env.rgb(x, y), pdf: if p.is_finite() && p > 0.0 { p as f32 } else { 0.0 } };
            }
        });
        let texels = uses_distribution.then(|| match warp {
            PerPixelWarp::Inversion => TexelSampler::Guided(GuidedDistribution::new(dist)),
            PerPixelWarp::Hierarchical => TexelSampler::Hierarchical(HierarchicalWarp::new(dist)),
        });
        Scene { env, grid, records, texels, kernel: cpu::fastest() }
    }

    #[inline]
    fn record(&self, x: usize, y: usize) -> &TexelRecord {
        &self.records[y * self.env.width + x]
    }

    /// Starts reading a texel's record early (a hint; no effect on results).
    #[inline(always)]
    fn prefetch_record(&self, (x, y): (usize, usize)) {
        prefetch(self.record(x, y));
    }

    /// One pixel's irradiance estimate `(1/spp) sum_j F_j` (see the module documentation) at
    /// unit normal `n`, in batches of [`BATCH`] samples, summed in sample order (`Mis`: each of
    /// the 16 lanes sums its samples in order, then the lanes are added in order). `spp == 0`
    /// gives zeros.
    #[allow(clippy::needless_range_loop)] // sample i of the batch arrays, in two stages
    fn estimate_irradiance(
        &self,
        n: DVec3,
        strategy: PerPixelStrategy,
        heuristic: Heuristic,
        spp: usize,
        uniforms: &mut PixelUniforms,
    ) -> [f64; 3] {
        if spp == 0 {
            return [0.0; 3];
        }
        let mut sum = [0.0f64; 3];
        let mut add = |l: [f32; 3], k: f64| {
            for ch in 0..3 {
                sum[ch] += l[ch] as f64 * k;
            }
        };
        let (b1, b2) = n.any_orthonormal_pair();
        let mut dirs = [DVec3::ZERO; BATCH];
        let mut texels = [(0usize, 0usize); 2 * BATCH];
        let mut batch_uniforms = [[0.0f64; BATCH]; 4];
        let mut cosine = CosineBatch { basis: [n, b1, b2], u: [[0.0f64; BATCH]; 2], grid: &self.grid };
        let mut cosine_guesses = [[0.0f64; BATCH]; 2];
        let mut mis = MisBatch {
            normal: n,
            heuristic,
            dir: [[[0.0; BATCH]; 3]; 2],
            radiance: [[[0.0; BATCH]; 3]; 2],
            pdf: [[0.0; BATCH]; 2],
        };
        let mut lane_sums = [[0.0f64; BATCH]; 3];
        // Lanes past a short batch's count compute from zeros or stale values; unused.
        let (mut env_band, mut env_v) = ([[0.0f64; BATCH]; 3], [0.0f64; BATCH]);
        let mut draws = BatchDraws { guided: [GuidedDraw::default(); BATCH], warp: [WarpDraw::default(); BATCH] };
        for start in (0..spp).step_by(BATCH) {
            let count = BATCH.min(spp - start);
            // Stage 1: directions and the texels they fall in (no reads of the records). The
            // distribution's searches come first, alone in their loop, so that the batch's
            // cache misses overlap.
            match strategy {
                PerPixelStrategy::Environment => {
                    let sampler = self.texels.as_ref().expect("built for this strategy");
                    uniforms.batch(self.kernel, start, count, 1, &mut batch_uniforms);
                    for i in 0..count {
                        sampler.start(&mut draws, i, batch_uniforms[0][i], batch_uniforms[1][i]);
                    }
                    sampler.resume(&mut draws, count);
                    for i in 0..count {
                        texels[i] = sampler.finish_texel(&draws, i);
                        self.prefetch_record(texels[i]);
                    }
                    for i in 0..count {
                        dirs[i] = DVec3::from(self.grid.centre_direction(texels[i].0, texels[i].1));
                    }
                }
                PerPixelStrategy::Cosine | PerPixelStrategy::Uniform => {
                    uniforms.batch(self.kernel, start, count, 1, &mut batch_uniforms);
                    for i in 0..count {
                        let (u1, u2) = (batch_uniforms[0][i], batch_uniforms[1][i]);
                        dirs[i] = if strategy == PerPixelStrategy::Cosine {
                            cosine_in_basis(n, b1, b2, u1, u2)
                        } else {
                            sample_uniform(u1, u2)
                        };
                        texels[i] = self.grid.texel_of(dirs[i].to_array());
                    }
                }
                PerPixelStrategy::Mis => {
                    let sampler = self.texels.as_ref().expect("built for this strategy");
                    // The environment technique's texel search runs in stages between which
                    // the batch's reads are prefetched (see `GuidedDistribution::start`); the
                    // cosine technique's arithmetic fills the wait.
                    uniforms.batch(self.kernel, start, count, 2, &mut batch_uniforms);
                    for i in 0..count {
                        sampler.start(&mut draws, i, batch_uniforms[0][i], batch_uniforms[1][i]);
                    }
                    cosine.u = [batch_uniforms[2], batch_uniforms[3]];
                    // Cosine technique: the directions (arithmetic only, while the guide
                    // entries arrive) ...
                    cosine_batch(self.kernel, &cosine, &mut mis.dir[1], &mut cosine_guesses);
                    sampler.resume(&mut draws, count);
                    // ... and the texels containing them (while the CDF entries arrive).
                    for i in 0..count {
                        let guess = [cosine_guesses[0][i], cosine_guesses[1][i]];
                        let d = [mis.dir[1][0][i], mis.dir[1][1][i], mis.dir[1][2][i]];
                        texels[2 * i + 1] = self.grid.texel_from_guess(d, guess);
                        self.prefetch_record(texels[2 * i + 1]);
                    }
                    for i in 0..count {
                        // Environment technique: the texel and, from where (u1, u2) fell in
                        // it, a point uniform in solid angle inside it.
                        let (x, y, rx, ry) = sampler.finish(&draws, i);
                        texels[2 * i] = (x, y);
                        self.prefetch_record((x, y));
                        let (c0, c1) = self.grid.row_edges_cos(y);
                        [env_band[0][i], env_band[1][i], env_band[2][i]] = [self.grid.turns_in_column(x, rx), c0, c1];
                        env_v[i] = ry;
                    }
                    band_point_batch(self.kernel, &env_band, &env_v, &mut mis.dir[0]);
                    // Stage 2: the records, then the weights and sums lane by lane.
                    for i in 0..count {
                        for t in 0..2 {
                            let r = self.record(texels[2 * i + t].0, texels[2 * i + t].1);
                            [mis.radiance[t][0][i], mis.radiance[t][1][i], mis.radiance[t][2][i]] = r.radiance;
                            mis.pdf[t][i] = r.pdf;
                        }
                    }
                    mis_batch(self.kernel, &mis, count, &mut lane_sums);
                }
            }
            // Stage 2: read the texels' records and accumulate, in sample order.
            for i in 0..count {
                match strategy {
                    PerPixelStrategy::Environment => {
                        let r = self.record(texels[i].0, texels[i].1);
                        if r.pdf > 0.0 {
                            add(r.radiance, n.dot(dirs[i]).max(0.0) / r.pdf as f64);
                        }
                    }
                    // f / p = L cos / (cos / pi) = pi L.
                    PerPixelStrategy::Cosine => add(self.env.rgb(texels[i].0, texels[i].1), PI),
                    PerPixelStrategy::Uniform => {
                        add(self.env.rgb(texels[i].0, texels[i].1), 4.0 * PI * n.dot(dirs[i]).max(0.0))
                    }
                    // Accumulated in stage 1's arm, lane by lane.
                    PerPixelStrategy::Mis => {}
                }
            }
        }
        // Mis's lane sums, in lane order (each lane summed its samples in order).
        for lane in 0..BATCH {
            for ch in 0..3 {
                sum[ch] += lane_sums[ch][lane];
            }
        }
        sum.map(|s| s / spp as f64)
    }
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
/// Speed (see BENCHMARKS.md): the texel is drawn through guide tables
/// ([`GuidedDistribution`], the same texel as `Distribution2D::sample`) or, with
/// [`PerPixelWarp::Hierarchical`], by the mip-map descent ([`HierarchicalWarp`]); texel directions,
/// solid angles and edges come from a [`LatLongGrid`], and directions are mapped to texels
/// without libm calls, so a sample costs a few table reads and no trigonometry.
///
/// Panics if the strategy uses `dist` and `dist` is not over a map of `env`'s size (the
/// operator checks this first).
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
    use crate::geometry::latlong;
    use crate::maths::reference::irradiance_exact;
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
    fn samplers_are_on_the_sphere_and_in_the_right_texel() {
        let mut rng = SplitMix64::new(5);
        let grid = LatLongGrid::new(16, 8);
        for _ in 0..10_000 {
            let n = sample_uniform(rng.next_f64(), rng.next_f64());
            assert!((n.dot(n) - 1.0).abs() < 1e-12);
            let (b1, b2) = n.any_orthonormal_pair();
            assert!(b1.dot(n).abs() < 1e-12 && b2.dot(n).abs() < 1e-12 && b1.dot(b2).abs() < 1e-12);
            let w = sample_cosine(n, rng.next_f64(), rng.next_f64());
            assert!((w.dot(w) - 1.0).abs() < 1e-12 && w.dot(n) >= -1e-12);
            let (x, y) = ((rng.next_f64() * 16.0) as usize, (rng.next_f64() * 8.0) as usize);
            let we = DVec3::from(grid.point_in_texel(x, y, rng.next_f64(), rng.next_f64()));
            assert!((we.dot(we) - 1.0).abs() < 1e-12);
            assert_eq!(latlong::texel_of_direction(we.to_array(), 16, 8), (x, y));
        }
    }

    /// Sample `j`'s request `k`, drawn one sample at a time as the batches' documentation
    /// describes (the reference [`PixelUniforms::batch`] is checked against).
    fn sequential_pair(u: &mut PixelUniforms, j: usize, k: usize) -> [f64; 2] {
        match &u.sobol {
            None if k == 0 => [u.rng.next_f64(), u.rng.next_f64()],
            None => {
                let r = u.rng.next_u64();
                [bits_to_unit((r >> 32) as u32), bits_to_unit(r as u32)]
            }
            Some(seeds) => {
                let [shuffle, sx, sy] = seeds[k];
                let [x, y] = sobol_2d_bits(nested_uniform_scramble(j as u32, shuffle));
                let low = u.rng.next_u64();
                let fill = |bits: u32, low21: u64| (((bits as u64) << 21) | low21) as f64 * (1.0 / (1u64 << 53) as f64);
                [
                    fill(nested_uniform_scramble(x, sx), low & 0x1F_FFFF),
                    fill(nested_uniform_scramble(y, sy), (low >> 21) & 0x1F_FFFF),
                ]
            }
        }
    }

    /// Batches (scalar and AVX-512) give the sequential draws' bits, full and short, with one
    /// request or two, and leave the generator where the sequential draws leave it.
    #[test]
    #[allow(clippy::needless_range_loop)] // lane i of several arrays
    fn batches_match_the_sequential_draws() {
        for sequence in PerPixelSequence::ALL {
            for requests in [1, 2] {
                for kernel in cpu::available::<BatchKernel>() {
                    let mut batched = PixelUniforms::new(sequence, pixel_seed(7, 3));
                    let mut sequential = PixelUniforms::new(sequence, pixel_seed(7, 3));
                    let mut start = 0;
                    for count in [16, 16, 5, 16, 1] {
                        let mut out = [[0.0; BATCH]; 4];
                        batched.batch(kernel, start, count, requests, &mut out);
                        for i in 0..count {
                            for k in 0..requests {
                                let want = sequential_pair(&mut sequential, start + i, k);
                                let got = [out[2 * k][i], out[2 * k + 1][i]];
                                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{sequence:?} {k}");
                            }
                        }
                        assert_eq!(batched.rng, sequential.rng);
                        start += count;
                    }
                }
            }
        }
    }

    /// Both sequences give values in [0, 1); Sobol's first 2^m points of a request, per pixel,
    /// put exactly one point in each of the 2^m columns (a (0, m, 2)-net's 1D projection).
    #[test]
    fn sobol_uniforms_are_stratified_per_pixel() {
        let draw = |sequence, pixel, samples: usize| {
            let mut u = PixelUniforms::new(sequence, pixel_seed(3, pixel));
            let mut pairs = vec![[[0.0; 2]; 2]; samples];
            for start in (0..samples).step_by(BATCH) {
                let mut out = [[0.0; BATCH]; 4];
                let count = BATCH.min(samples - start);
                u.batch(cpu::fastest(), start, count, 2, &mut out);
                for i in 0..count {
                    pairs[start + i] = [[out[0][i], out[1][i]], [out[2][i], out[3][i]]];
                }
            }
            pairs
        };
        for pixel in 0..20u64 {
            let pairs = draw(PerPixelSequence::Sobol, pixel, 64);
            for k in 0..2 {
                let mut columns = [0usize; 64];
                let mut rows = [0usize; 64];
                for [a, b] in pairs.iter().map(|p| p[k]) {
                    assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
                    columns[(a * 64.0) as usize] += 1;
                    rows[(b * 64.0) as usize] += 1;
                }
                assert!(columns.iter().chain(&rows).all(|&c| c == 1), "pixel {pixel} request {k}");
            }
        }
        let pairs = draw(PerPixelSequence::Random, 1, 1000);
        assert!(pairs.iter().flatten().flatten().all(|v| (0.0..1.0).contains(v)));
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

    /// The AVX-512 batch functions (where this processor has them) give the scalar lanes' bits,
    /// so an image does not depend on the machine either.
    #[test]
    fn batch_functions_match_their_scalar_lanes() {
        if !cpu::runs(BatchKernel::Avx512) {
            eprintln!("no AVX-512 here: only the scalar lanes run");
            return;
        }
        let mut rng = SplitMix64::new(41);
        let grid = LatLongGrid::new(64, 32);
        for round in 0..2000 {
            let n = sample_uniform(rng.next_f64(), rng.next_f64());
            let (b1, b2) = n.any_orthonormal_pair();
            let mut cosine = CosineBatch { basis: [n, b1, b2], u: [[0.0; BATCH]; 2], grid: &grid };
            let u = &mut cosine.u;
            let mut band = [[0.0; BATCH]; 3];
            let mut v = [0.0; BATCH];
            for i in 0..BATCH {
                u[0][i] = rng.next_f64();
                u[1][i] = rng.next_f64();
                let (x, y) = ((rng.next_f64() * 64.0) as usize, (rng.next_f64() * 32.0) as usize);
                let (c0, c1) = grid.row_edges_cos(y);
                band[0][i] = grid.turns_in_column(x, rng.next_f64());
                [band[1][i], band[2][i]] = [c0, c1];
                v[i] = rng.next_f64();
            }
            if round == 0 {
                // The ends of the unit interval.
                u[0][0] = 0.0;
                u[1][1] = 0.0;
                u[0][2] = 1.0 - f64::EPSILON / 2.0;
                band[0][3] = 1.0;
                v[4] = 0.0;
            }
            let (mut scalar, mut wide) = ([[0.0; BATCH]; 3], [[0.0; BATCH]; 3]);
            let (mut scalar_guess, mut wide_guess) = ([[0.0; BATCH]; 2], [[0.0; BATCH]; 2]);
            cosine_batch_lanes(&cosine, &mut scalar, &mut scalar_guess);
            cosine_batch(BatchKernel::Avx512, &cosine, &mut wide, &mut wide_guess);
            assert_eq!(scalar.map(|a| a.map(f64::to_bits)), wide.map(|a| a.map(f64::to_bits)));
            assert_eq!(scalar_guess.map(|a| a.map(f64::to_bits)), wide_guess.map(|a| a.map(f64::to_bits)));
            band_point_lanes(&band, &v, &mut scalar);
            band_point_batch(BatchKernel::Avx512, &band, &v, &mut wide);
            assert_eq!(scalar.map(|a| a.map(f64::to_bits)), wide.map(|a| a.map(f64::to_bits)));
            // Stage 2 of Mis on those directions, some densities 0 (as below the horizon).
            let heuristic = Heuristic::ALL[round % 2];
            let mut mis = MisBatch {
                normal: n,
                heuristic,
                dir: [scalar, wide],
                radiance: [[[0.0; BATCH]; 3]; 2],
                pdf: [[0.0; BATCH]; 2],
            };
            for t in 0..2 {
                for i in 0..BATCH {
                    mis.pdf[t][i] = if i % 5 == 0 { 0.0 } else { rng.next_f64() as f32 * 3.0 };
                    for ch in 0..3 {
                        mis.radiance[t][ch][i] = rng.next_f64() as f32 * 10.0;
                    }
                }
            }
            let count = 1 + round % BATCH;
            let (mut scalar_sums, mut wide_sums) = ([[0.5; BATCH]; 3], [[0.5; BATCH]; 3]);
            mis_lanes(&mis, count, &mut scalar_sums);
            mis_batch(BatchKernel::Avx512, &mis, count, &mut wide_sums);
            assert_eq!(scalar_sums.map(|a| a.map(f64::to_bits)), wide_sums.map(|a| a.map(f64::to_bits)));
            assert!(scalar_sums.iter().all(|lanes| lanes[count..].iter().all(|&v| v == 0.5)), "lanes past count");
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
