//! The batch's lane loops: a batch of [`BATCH`] samples as structure-of-arrays loops over its
//! lanes, each compiled for AVX-512 and for the baseline ([`avx512_batch!`]) with the same bits;
//! the cosine and uniform directions, the points inside environment texels and `Mis`'s weights.

use std::f64::consts::PI;

use glam::DVec3;

use crate::cpu;
use crate::geometry::latlong_grid::{point_in_band, sincos_turns, LatLongGrid};
use crate::maths::sampling::mis::Heuristic;

/// Which compilation of the batch lane loops runs (see [`avx512_batch!`]): both give the same bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum BatchKernel {
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
/// give the same bits. `$batch` has visibility `$vis`; [`BatchKernel`] must be in scope.
macro_rules! avx512_batch {
    ($(#[$doc:meta])* $vis:vis fn $batch:ident / $avx512:ident = $lanes:ident($($arg:ident: $ty:ty),* $(,)?)) => {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512dq")]
        unsafe fn $avx512($($arg: $ty),*) {
            $lanes($($arg),*)
        }

        $(#[$doc])*
        #[inline(always)]
        $vis fn $batch(kernel: BatchKernel, $($arg: $ty),*) {
            #[cfg(target_arch = "x86_64")]
            if kernel == BatchKernel::Avx512 && $crate::cpu::has_avx512() {
                // SAFETY: the processor has AVX-512F and DQ (checked just above).
                return unsafe { $avx512($($arg),*) };
            }
            let _ = kernel;
            $lanes($($arg),*)
        }
    };
}
pub(super) use avx512_batch;

/// Samples processed per batch: the texels of a batch are found first and read second, so the
/// processor has a batch's worth of independent memory reads in flight instead of one chain per
/// sample (the tables exceed the L2 cache on a 1024x512 map).
pub(super) const BATCH: usize = 16;

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
pub(super) fn cosine_in_basis(n: DVec3, b1: DVec3, b2: DVec3, u1: f64, u2: f64) -> DVec3 {
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
pub(super) struct CosineBatch<'g> {
    pub(super) basis: [DVec3; 3],
    pub(super) u: [[f64; BATCH]; 2],
    pub(super) grid: &'g LatLongGrid,
}

avx512_batch! {
    /// [`cosine_batch_lanes`], with AVX-512 when asked and the processor has it.
    pub(super) fn cosine_batch / cosine_batch_avx512 = cosine_batch_lanes(
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
    pub(super) fn band_point_batch / band_point_avx512 = band_point_lanes(
        band: &[[f64; BATCH]; 3],
        v: &[f64; BATCH],
        out: &mut [[f64; BATCH]; 3]
    )
}

/// A `Mis` batch's stage 2 inputs, structure of arrays, technique `t` (0 environment, 1
/// cosine) and lane `i`: the direction `dir[t][axis][i]`, the record's radiance
/// `radiance[t][channel][i]` and environment density `pdf[t][i]`.
pub(super) struct MisBatch {
    pub(super) normal: DVec3,
    pub(super) heuristic: Heuristic,
    pub(super) dir: [[[f64; BATCH]; 3]; 2],
    pub(super) radiance: [[[f32; BATCH]; 3]; 2],
    pub(super) pdf: [[f32; BATCH]; 2],
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
    pub(super) fn mis_batch / mis_avx512 = mis_lanes(batch: &MisBatch, count: usize, sums: &mut [[f64; BATCH]; 3])
}

/// A uniform direction on the unit sphere (pdf `1 / (4 pi)`).
#[inline]
pub(super) fn sample_uniform(u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sincos_turns(u2);
    DVec3::new(r * c, r * s, z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;
    use crate::maths::sampling::sequences::SplitMix64;

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

    #[test]
    fn batch_functions_match_their_scalar_lanes() {
        if !cpu::runs(BatchKernel::Avx512) {
            return crate::test_skip::skip("HDRFLOW_REQUIRE_AVX512", "no AVX-512 here: only the scalar lanes run");
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
}
