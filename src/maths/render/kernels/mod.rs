//! The inner loop shared by the relighting sums, and the back-face culling test that lets them
//! skip work: one implementation for [`crate::maths::render::relight`] (RelightSphere, the lights are samples)
//! and [`crate::maths::render::reference`] (ReferenceSphere, the lights are the map's texels).
//!
//! Both evaluate, for a unit normal `n` and lights of direction `d_j` and weight `w_j` (RGB),
//!
//! ```text
//! s(n) = sum_j max(n . d_j, 0) w_j
//! ```
//!
//! the clamped cosine of Lambert's law (pbrt-v4 section 4.2 for irradiance from radiance).
//!
//! # Layout and kernels
//!
//! Lights are packed as structure of arrays in [`Block`]s of [`LANES`] = 8 (one AVX register, or
//! two SSE registers, per component); padding lanes have direction 0 and weight 0 and add exactly
//! `+0`. Every kernel computes, in each lane and in f32, the same operations in the same order:
//!
//! - `dot = (nx dx + ny dy) + nz dz` (three products, two additions, left to right);
//! - `c = max(dot, 0)` with the semantics of `MAXPS(dot, 0)`: `+0` when `dot` is not greater
//!   than 0, so NaN and `-0` give `+0`;
//! - `acc += c * w` per channel, a product then a sum (no FMA contraction);
//!
//! and after the last block sums the 8 lanes in one fixed pairwise order (`hsum`). The
//! kernel is chosen at run time by the `crate::cpu` level ([`Kernel::at`]): AVX-512 (four normals
//! per pass, two per register, each light block broadcast to both halves), AVX at `avx2` (two
//! normals per pass, sharing the light loads), SSE2 at `portable` on x86_64 (the baseline), and one
//! portable scalar loop elsewhere (also the reference the tests compare the others with). Results are
//! therefore bit-identical on every CPU, whatever the kernel, the number of threads and the
//! order in which normals are passed.
//!
//! # Culling
//!
//! A light with `n . d <= 0` for every normal `n` of a group (a tile of pixels) adds exactly `+0`
//! to each of their sums, so it may be skipped. [`Cone`] bounds a set of directions; the test
//! [`Cone::cull_threshold`] is written for a cone of normals (axis `c`, half-angle `t`) and a
//! cone of lights (axis `a`, half-angle `b`; `b = 0` for one light) whose axes are `gamma`
//! apart. Geometry: every normal is within `t` of `c`, every light within `b` of `a`, so every
//! pair is at least `gamma - t - b` apart (triangle inequality on the sphere), and all pairs
//! face away from each other once `gamma >= 90 deg + t + b`, i.e. `cos gamma <= -sin(t + b)`
//! (for `t + b < 90 deg`; otherwise nothing is culled). The test keeps a margin `M`
//! ([`CULL_MARGIN`]):
//!
//! ```text
//! cull  <=>  t + b < 90 deg  and  cos gamma <= -(sin(t + b) + M)
//! ```
//!
//! ## Why `M` makes the test safe in f32
//!
//! The kernels do not see `n . d` but its f32 evaluation, so a light is skipped only if that
//! evaluation is `<= 0` for every pair. With `u = 2^-24` (f32 unit roundoff):
//!
//! 1. Margin in angle: `cos gamma <= -(sin(t + b) + M)` gives `gamma >= 90 deg + asin(sin(t + b)
//!    + M) >= 90 deg + (t + b) + M` (`asin` has slope >= 1), so every pair is at least
//!    `90 deg + M` apart: `n^ . d^ <= -sin M` for the unit vectors `n^`, `d^`.
//! 2. Input rounding: the kernel uses `nf = fl32(n)` and `df = fl32(d)` (`df = d` when the
//!    directions are f32 already, as RelightSphere's are), each component with relative error
//!    `<= u`, so `nf . df <= |n| |d| (n^ . d^ + 2u + u^2)`.
//! 3. The f32 dot product of 3 terms errs by at most `gamma_3 sum_i |nf_i df_i| <=
//!    gamma_3 |nf| |df|`, `gamma_3 = 3u / (1 - 3u)` (Higham, *Accuracy and Stability of
//!    Numerical Algorithms*, 2nd ed., 2002, eq. 3.5, and Cauchy-Schwarz), with
//!    `|nf| |df| <= (1 + u)^2 |n| |d|`.
//! 4. The test itself runs in f64: cone axes, `cos t` as a minimum of dot products, `sin t =
//!    sqrt(1 - cos^2 t)`, `sin(t + b)` by the addition formula. All err by ~1e-15 except the sine
//!    taken from a cosine near 1, where an error `e` in `cos t` moves `sin t` by up to
//!    `sqrt(2e)`: ~5e-8 for `e ~ 1e-15`.
//!
//! So the f32 dot is `<= |n| |d| (-sin M + 2u + gamma_3 (1 + u)^2 + ~5e-8 + O(u^2))`
//! `= |n| |d| (-sin M + ~3.5e-7)`, which is `<= 0` for any `M >= ~3.5e-7` (barring underflow:
//! normals and directions much longer than 1e-30, as unit ones are). Then `c = +0`, `c * w = +-0`
//! for finite `w`, and `acc + (+-0) = acc` bit for bit (acc starts at `+0`): a culled light
//! changes no bit of any sum. Non-finite weights are excluded by the callers (`0 * Inf = NaN`).
//!
//! `M = 1e-4` is about 300 times that bound. It is the margin RelightSphere has always used,
//! and it must stay so: RelightSphere packs only the lights it keeps, so culling one more or one
//! fewer light moves the later lights to other lanes and changes the f32 rounding of its sums
//! (the values, not their accuracy). A smaller margin would buy nothing measurable (lights in a
//! band 0.006 degree wide past a tile's horizon) and would change RelightSphere's renders by an
//! ulp here and there. ReferenceSphere adds each tile's f32 sum into f64 and skips whole tiles, so
//! its results do not depend on what is culled (its tests check culling on and off bit for bit);
//! it used an angle margin of 1e-3 rad before the two tests were merged.

use glam::DVec3;

use crate::cpu::{self, Level};
use crate::geometry::unit;

/// Lights per [`Block`]: one AVX register, or two SSE registers, of f32.
pub const LANES: usize = 8;

/// Margin of the culling test, in cosine (see the module documentation for its derivation:
/// anything above ~3.5e-7 is safe; 1e-4 keeps RelightSphere's renders bit for bit as they were).
pub const CULL_MARGIN: f64 = 1e-4;

/// `N` lights as structure of arrays: direction and RGB weight per lane, aligned for AVX-512
/// loads. [`SoaBlock::ZERO`] is all padding (direction 0, weight 0: adds exactly `+0`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct SoaBlock<const N: usize> {
    pub dx: [f32; N],
    pub dy: [f32; N],
    pub dz: [f32; N],
    pub wr: [f32; N],
    pub wg: [f32; N],
    pub wb: [f32; N],
}

impl<const N: usize> SoaBlock<N> {
    /// A block of padding lanes.
    pub const ZERO: Self =
        SoaBlock { dx: [0.0; N], dy: [0.0; N], dz: [0.0; N], wr: [0.0; N], wg: [0.0; N], wb: [0.0; N] };
}

/// [`LANES`] lights: the layout of [`Kernel::for_each_sum`] (RelightSphere).
pub type Block = SoaBlock<LANES>;

/// [`WIDE`] lights: the layout of [`Kernel::accumulate_wide`] (the exact reference).
pub type WideBlock = SoaBlock<WIDE>;

/// Appends `lights` (direction, weight) to `blocks` in order, `N` per block (light `k` in lane
/// `k % N`), the last block padded with zero lanes.
pub fn pack_blocks<const N: usize>(
    lights: impl IntoIterator<Item = ([f32; 3], [f32; 3])>,
    blocks: &mut Vec<SoaBlock<N>>,
) {
    for (k, (d, w)) in lights.into_iter().enumerate() {
        let lane = k % N;
        if lane == 0 {
            blocks.push(SoaBlock::ZERO);
        }
        let b = blocks.last_mut().expect("a block was pushed");
        (b.dx[lane], b.dy[lane], b.dz[lane]) = (d[0], d[1], d[2]);
        (b.wr[lane], b.wg[lane], b.wb[lane]) = (w[0], w[1], w[2]);
    }
}

/// The sum of the 8 lanes in one fixed pairwise order, the same in every kernel.
#[inline(always)]
fn hsum(a: &[f32; LANES]) -> f32 {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// The portable kernel, reference for the SIMD ones: `sum_j max(n . d_j, 0) w_j` over `blocks`.
#[allow(clippy::needless_range_loop)] // lane l of every array: the SIMD layout, written out
fn sum_scalar(blocks: &[Block], n: [f32; 3]) -> [f32; 3] {
    let mut acc = [[0.0f32; LANES]; 3];
    for b in blocks {
        for l in 0..LANES {
            let d = n[0] * b.dx[l] + n[1] * b.dy[l] + n[2] * b.dz[l];
            // MAXPS(d, 0): NaN and -0 give +0.
            let c = if d > 0.0 { d } else { 0.0 };
            acc[0][l] += c * b.wr[l];
            acc[1][l] += c * b.wg[l];
            acc[2][l] += c * b.wb[l];
        }
    }
    [hsum(&acc[0]), hsum(&acc[1]), hsum(&acc[2])]
}

/// Lanes per [`WideBlock`]: one AVX-512 register of f32.
pub const WIDE: usize = 16;

/// Per-lane f64 accumulators of one normal's sums: `[channel][lane]`. See
/// [`Kernel::accumulate_wide`].
pub type WideSums = [[f64; WIDE]; 3];

/// The total of a normal's [`WideSums`], per channel: the 16 lanes added in one fixed pairwise
/// order, in f64.
#[inline]
pub fn wide_total(s: &WideSums) -> [f64; 3] {
    s.map(|a| {
        let q = |i: usize| (a[i] + a[i + 8]) + (a[i + 4] + a[i + 12]);
        (q(0) + q(1)) + (q(2) + q(3))
    })
}

/// The portable wide kernel, reference for the SIMD ones: per lane, the f32 sum over `blocks`
/// of `max(n . d, 0) w`, with fused multiply-adds (`d = fma(nz, dz, fma(ny, dy, nx dx))`,
/// `acc = fma(c, w, acc)`: 7 operations a term instead of 12, each rounded once), added into
/// `acc` in f64. `f32::mul_add` is IEEE's fused operation on every CPU, so every kernel gives
/// the same bits; where the CPU has no FMA (x86-64 before 2013) it is a library call, 50x slower.
#[allow(clippy::needless_range_loop)] // lane l of every array: the SIMD layout, written out
fn wide_scalar(blocks: &[WideBlock], n: [f32; 3], acc: &mut WideSums) {
    let mut lane = [[0.0f32; WIDE]; 3];
    for b in blocks {
        for l in 0..WIDE {
            let d = n[2].mul_add(b.dz[l], n[1].mul_add(b.dy[l], n[0] * b.dx[l]));
            let c = if d > 0.0 { d } else { 0.0 };
            lane[0][l] = c.mul_add(b.wr[l], lane[0][l]);
            lane[1][l] = c.mul_add(b.wg[l], lane[1][l]);
            lane[2][l] = c.mul_add(b.wb[l], lane[2][l]);
        }
    }
    for ch in 0..3 {
        for l in 0..WIDE {
            acc[ch][l] += lane[ch][l] as f64;
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{hsum, Block, WideBlock, WideSums, LANES};
    use std::arch::x86_64::*;

    /// AVX: `sum_scalar` for two normals at once, one register per block component. The light
    /// loads are shared; each normal's lane arithmetic is exactly the scalar one.
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn sum2_avx(blocks: &[Block], a: [f32; 3], b: [f32; 3]) -> [[f32; 3]; 2] {
        let (ax, ay, az) = (_mm256_set1_ps(a[0]), _mm256_set1_ps(a[1]), _mm256_set1_ps(a[2]));
        let (bx, by, bz) = (_mm256_set1_ps(b[0]), _mm256_set1_ps(b[1]), _mm256_set1_ps(b[2]));
        let zero = _mm256_setzero_ps();
        let mut acc = [zero; 6]; // a: r, g, b; b: r, g, b
        for g in blocks {
            // Aligned loads: `Block` is `align(64)`.
            let dx = _mm256_load_ps(g.dx.as_ptr());
            let dy = _mm256_load_ps(g.dy.as_ptr());
            let dz = _mm256_load_ps(g.dz.as_ptr());
            let wr = _mm256_load_ps(g.wr.as_ptr());
            let wg = _mm256_load_ps(g.wg.as_ptr());
            let wb = _mm256_load_ps(g.wb.as_ptr());
            let da = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, dx), _mm256_mul_ps(ay, dy)), _mm256_mul_ps(az, dz));
            let db = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(bx, dx), _mm256_mul_ps(by, dy)), _mm256_mul_ps(bz, dz));
            // MAXPS returns the second operand when the first is not greater (NaN, -0 -> +0).
            let ca = _mm256_max_ps(da, zero);
            let cb = _mm256_max_ps(db, zero);
            acc[0] = _mm256_add_ps(acc[0], _mm256_mul_ps(ca, wr));
            acc[1] = _mm256_add_ps(acc[1], _mm256_mul_ps(ca, wg));
            acc[2] = _mm256_add_ps(acc[2], _mm256_mul_ps(ca, wb));
            acc[3] = _mm256_add_ps(acc[3], _mm256_mul_ps(cb, wr));
            acc[4] = _mm256_add_ps(acc[4], _mm256_mul_ps(cb, wg));
            acc[5] = _mm256_add_ps(acc[5], _mm256_mul_ps(cb, wb));
        }
        let mut lanes = [[0.0f32; LANES]; 6];
        for k in 0..6 {
            _mm256_storeu_ps(lanes[k].as_mut_ptr(), acc[k]);
        }
        [[hsum(&lanes[0]), hsum(&lanes[1]), hsum(&lanes[2])], [hsum(&lanes[3]), hsum(&lanes[4]), hsum(&lanes[5])]]
    }

    /// AVX-512: `sum_scalar` for four normals at once. Each 512-bit register holds one block
    /// component twice (the 8 lanes broadcast to both halves) or two normals (a, b in the low
    /// and high halves; c, d in a second register), so every lane does exactly the scalar
    /// kernel's operations for its normal and block lane: the same bits as `Scalar` and `Avx`,
    /// with half the instructions per term of `Avx` (12 vector operations per block and pair of
    /// normals, 16 terms each).
    #[target_feature(enable = "avx512f,avx512dq")]
    pub(super) unsafe fn sum4_avx512(blocks: &[Block], n: [[f32; 3]; 4]) -> [[f32; 3]; 4] {
        let pair =
            |lo: f32, hi: f32| _mm512_insertf32x8::<1>(_mm512_castps256_ps512(_mm256_set1_ps(lo)), _mm256_set1_ps(hi));
        let ab = [pair(n[0][0], n[1][0]), pair(n[0][1], n[1][1]), pair(n[0][2], n[1][2])];
        let cd = [pair(n[2][0], n[3][0]), pair(n[2][1], n[3][1]), pair(n[2][2], n[3][2])];
        let zero = _mm512_setzero_ps();
        let mut acc = [zero; 6]; // ab: r, g, b; cd: r, g, b
        for g in blocks {
            // Aligned 256-bit loads (`Block` is `align(64)`), broadcast to both halves.
            let load = |p: *const f32| _mm512_broadcast_f32x8(_mm256_load_ps(p));
            let dx = load(g.dx.as_ptr());
            let dy = load(g.dy.as_ptr());
            let dz = load(g.dz.as_ptr());
            let wr = load(g.wr.as_ptr());
            let wg = load(g.wg.as_ptr());
            let wb = load(g.wb.as_ptr());
            let d1 = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(ab[0], dx), _mm512_mul_ps(ab[1], dy)),
                _mm512_mul_ps(ab[2], dz),
            );
            let d2 = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(cd[0], dx), _mm512_mul_ps(cd[1], dy)),
                _mm512_mul_ps(cd[2], dz),
            );
            // VMAXPS returns the second operand when the first is not greater (NaN, -0 -> +0).
            let c1 = _mm512_max_ps(d1, zero);
            let c2 = _mm512_max_ps(d2, zero);
            acc[0] = _mm512_add_ps(acc[0], _mm512_mul_ps(c1, wr));
            acc[1] = _mm512_add_ps(acc[1], _mm512_mul_ps(c1, wg));
            acc[2] = _mm512_add_ps(acc[2], _mm512_mul_ps(c1, wb));
            acc[3] = _mm512_add_ps(acc[3], _mm512_mul_ps(c2, wr));
            acc[4] = _mm512_add_ps(acc[4], _mm512_mul_ps(c2, wg));
            acc[5] = _mm512_add_ps(acc[5], _mm512_mul_ps(c2, wb));
        }
        let mut lanes = [[0.0f32; 2 * LANES]; 6];
        for k in 0..6 {
            _mm512_storeu_ps(lanes[k].as_mut_ptr(), acc[k]);
        }
        let half =
            |k: usize, h: usize| -> [f32; LANES] { lanes[k][h * LANES..(h + 1) * LANES].try_into().expect("8 lanes") };
        let sum =
            |first: usize, h: usize| [hsum(&half(first, h)), hsum(&half(first + 1, h)), hsum(&half(first + 2, h))];
        [sum(0, 0), sum(0, 1), sum(3, 0), sum(3, 1)]
    }

    /// Adds 8 f32 lanes into 8 f64 accumulators (two 4-lane conversions).
    #[target_feature(enable = "avx")]
    unsafe fn add_lanes_avx(v: __m256, acc: &mut [f64]) {
        let lo = _mm256_cvtps_pd(_mm256_castps256_ps128(v));
        let hi = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(v));
        _mm256_storeu_pd(acc.as_mut_ptr(), _mm256_add_pd(_mm256_loadu_pd(acc.as_ptr()), lo));
        _mm256_storeu_pd(acc.as_mut_ptr().add(4), _mm256_add_pd(_mm256_loadu_pd(acc.as_ptr().add(4)), hi));
    }

    /// AVX and FMA: `wide_scalar` for one normal, each 16-lane component in two registers.
    #[target_feature(enable = "avx,fma")]
    pub(super) unsafe fn wide1_avx(blocks: &[WideBlock], n: [f32; 3], acc: &mut WideSums) {
        let (nx, ny, nz) = (_mm256_set1_ps(n[0]), _mm256_set1_ps(n[1]), _mm256_set1_ps(n[2]));
        let zero = _mm256_setzero_ps();
        let mut lane = [zero; 6]; // r lo, r hi, g lo, g hi, b lo, b hi
        for g in blocks {
            for half in 0..2 {
                let o = 8 * half;
                let d = _mm256_fmadd_ps(
                    nz,
                    _mm256_load_ps(g.dz.as_ptr().add(o)),
                    _mm256_fmadd_ps(
                        ny,
                        _mm256_load_ps(g.dy.as_ptr().add(o)),
                        _mm256_mul_ps(nx, _mm256_load_ps(g.dx.as_ptr().add(o))),
                    ),
                );
                let c = _mm256_max_ps(d, zero);
                lane[half] = _mm256_fmadd_ps(c, _mm256_load_ps(g.wr.as_ptr().add(o)), lane[half]);
                lane[2 + half] = _mm256_fmadd_ps(c, _mm256_load_ps(g.wg.as_ptr().add(o)), lane[2 + half]);
                lane[4 + half] = _mm256_fmadd_ps(c, _mm256_load_ps(g.wb.as_ptr().add(o)), lane[4 + half]);
            }
        }
        for ch in 0..3 {
            add_lanes_avx(lane[2 * ch], &mut acc[ch][..8]);
            add_lanes_avx(lane[2 * ch + 1], &mut acc[ch][8..]);
        }
    }

    /// AVX-512: `wide_scalar` for two normals at once, one register per block component (plain
    /// aligned loads: a broadcast costs a shuffle, which competes with the adds).
    #[target_feature(enable = "avx512f,avx512dq")]
    pub(super) unsafe fn wide2_avx512(blocks: &[WideBlock], a: [f32; 3], b: [f32; 3], acc: [&mut WideSums; 2]) {
        let (ax, ay, az) = (_mm512_set1_ps(a[0]), _mm512_set1_ps(a[1]), _mm512_set1_ps(a[2]));
        let (bx, by, bz) = (_mm512_set1_ps(b[0]), _mm512_set1_ps(b[1]), _mm512_set1_ps(b[2]));
        let zero = _mm512_setzero_ps();
        let mut lane = [zero; 6]; // a: r, g, b; b: r, g, b
        for g in blocks {
            let dx = _mm512_load_ps(g.dx.as_ptr());
            let dy = _mm512_load_ps(g.dy.as_ptr());
            let dz = _mm512_load_ps(g.dz.as_ptr());
            let wr = _mm512_load_ps(g.wr.as_ptr());
            let wg = _mm512_load_ps(g.wg.as_ptr());
            let wb = _mm512_load_ps(g.wb.as_ptr());
            let da = _mm512_fmadd_ps(az, dz, _mm512_fmadd_ps(ay, dy, _mm512_mul_ps(ax, dx)));
            let db = _mm512_fmadd_ps(bz, dz, _mm512_fmadd_ps(by, dy, _mm512_mul_ps(bx, dx)));
            let ca = _mm512_max_ps(da, zero);
            let cb = _mm512_max_ps(db, zero);
            lane[0] = _mm512_fmadd_ps(ca, wr, lane[0]);
            lane[1] = _mm512_fmadd_ps(ca, wg, lane[1]);
            lane[2] = _mm512_fmadd_ps(ca, wb, lane[2]);
            lane[3] = _mm512_fmadd_ps(cb, wr, lane[3]);
            lane[4] = _mm512_fmadd_ps(cb, wg, lane[4]);
            lane[5] = _mm512_fmadd_ps(cb, wb, lane[5]);
        }
        let [acc_a, acc_b] = acc;
        let add = |v: __m256, acc: &mut [f64]| {
            _mm512_storeu_pd(acc.as_mut_ptr(), _mm512_add_pd(_mm512_loadu_pd(acc.as_ptr()), _mm512_cvtps_pd(v)));
        };
        for ch in 0..3 {
            add(_mm512_castps512_ps256(lane[ch]), &mut acc_a[ch][..8]);
            add(_mm512_extractf32x8_ps::<1>(lane[ch]), &mut acc_a[ch][8..]);
            add(_mm512_castps512_ps256(lane[3 + ch]), &mut acc_b[ch][..8]);
            add(_mm512_extractf32x8_ps::<1>(lane[3 + ch]), &mut acc_b[ch][8..]);
        }
    }

    /// SSE2: `sum_scalar` with lanes 0-3 and 4-7 of each component in two registers.
    pub(super) unsafe fn sum_sse2(blocks: &[Block], n: [f32; 3]) -> [f32; 3] {
        let (nx, ny, nz) = (_mm_set1_ps(n[0]), _mm_set1_ps(n[1]), _mm_set1_ps(n[2]));
        let zero = _mm_setzero_ps();
        let mut acc = [zero; 6]; // r lo, r hi, g lo, g hi, b lo, b hi
        for g in blocks {
            for half in 0..2 {
                let o = 4 * half;
                let d = _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(nx, _mm_load_ps(g.dx.as_ptr().add(o))),
                        _mm_mul_ps(ny, _mm_load_ps(g.dy.as_ptr().add(o))),
                    ),
                    _mm_mul_ps(nz, _mm_load_ps(g.dz.as_ptr().add(o))),
                );
                let c = _mm_max_ps(d, zero);
                acc[half] = _mm_add_ps(acc[half], _mm_mul_ps(c, _mm_load_ps(g.wr.as_ptr().add(o))));
                acc[2 + half] = _mm_add_ps(acc[2 + half], _mm_mul_ps(c, _mm_load_ps(g.wg.as_ptr().add(o))));
                acc[4 + half] = _mm_add_ps(acc[4 + half], _mm_mul_ps(c, _mm_load_ps(g.wb.as_ptr().add(o))));
            }
        }
        let mut lanes = [[0.0f32; LANES]; 3];
        for ch in 0..3 {
            _mm_storeu_ps(lanes[ch].as_mut_ptr(), acc[2 * ch]);
            _mm_storeu_ps(lanes[ch].as_mut_ptr().add(4), acc[2 * ch + 1]);
        }
        [hsum(&lanes[0]), hsum(&lanes[1]), hsum(&lanes[2])]
    }
}

/// Which implementation of the inner loop runs; all give bit-identical results (see the module
/// documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// The portable loop: the only one off x86_64, and the reference in tests.
    Scalar,
    /// Level `portable` on x86_64 (SSE2 is part of the x86_64 baseline).
    #[cfg(target_arch = "x86_64")]
    Sse2,
    /// Level `avx2`: AVX (with FMA in `accumulate_wide`).
    #[cfg(target_arch = "x86_64")]
    Avx,
    /// Level `avx512` (AVX-512 F and DQ): four normals per pass.
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Kernel {
    /// The kernel `level` runs (`cpu::level` for the relighting sums and the exact reference):
    /// SSE2 for `portable` on x86_64 (the scalar loop elsewhere), AVX for `avx2` (with FMA in
    /// [`Kernel::accumulate_wide`]), AVX-512 for `avx512`.
    pub fn at(level: Level) -> Kernel {
        #[cfg(target_arch = "x86_64")]
        return match level {
            Level::Portable => Kernel::Sse2,
            Level::Avx2 => Kernel::Avx,
            Level::Avx512 => Kernel::Avx512,
        };
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = level;
            Kernel::Scalar
        }
    }
}

impl Kernel {
    /// Calls `out(i, s(normals[i]))` for every normal, in order, with
    /// `s(n) = sum_j max(n . d_j, 0) w_j` over the lights of `blocks` (summed in f32 as the module
    /// documentation says). The AVX kernel takes the normals two at a time. Asked for on a CPU
    /// without its level (`cpu::supports`), a kernel runs the SSE2 one instead (the same bits;
    /// checked on every call, a cached atomic load), so any `Kernel` value is safe to pass.
    #[inline]
    pub fn for_each_sum(self, blocks: &[Block], normals: &[[f32; 3]], mut out: impl FnMut(usize, [f32; 3])) {
        match self {
            Kernel::Scalar => {
                for (i, &n) in normals.iter().enumerate() {
                    out(i, sum_scalar(blocks, n));
                }
            }
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512 if cpu::supports(Level::Avx512) => {
                let mut quads = normals.chunks_exact(4);
                for (k, q) in quads.by_ref().enumerate() {
                    // SAFETY: the CPU has AVX-512 F and DQ (the match guard).
                    let s = unsafe { x86::sum4_avx512(blocks, [q[0], q[1], q[2], q[3]]) };
                    for (j, sum) in s.into_iter().enumerate() {
                        out(4 * k + j, sum);
                    }
                }
                let rest = quads.remainder();
                if let Some(&last) = rest.last() {
                    // SAFETY: as above. The last one to three normals, padded with the last.
                    let q = [0, 1, 2, 3].map(|j| *rest.get(j).unwrap_or(&last));
                    let s = unsafe { x86::sum4_avx512(blocks, q) };
                    let start = normals.len() - rest.len();
                    for (j, sum) in s.into_iter().take(rest.len()).enumerate() {
                        out(start + j, sum);
                    }
                }
            }
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx | Kernel::Avx512 if cpu::supports(Level::Avx2) => {
                let mut pairs = normals.chunks_exact(2);
                for (k, pair) in pairs.by_ref().enumerate() {
                    // SAFETY: the CPU has AVX (the match guard: level `avx2` includes it).
                    let s = unsafe { x86::sum2_avx(blocks, pair[0], pair[1]) };
                    out(2 * k, s[0]);
                    out(2 * k + 1, s[1]);
                }
                if let [last] = pairs.remainder() {
                    // SAFETY: as above. The unpaired last normal rides with itself.
                    let s = unsafe { x86::sum2_avx(blocks, *last, *last) };
                    out(normals.len() - 1, s[0]);
                }
            }
            #[cfg(target_arch = "x86_64")]
            Kernel::Sse2 | Kernel::Avx | Kernel::Avx512 => {
                for (i, &n) in normals.iter().enumerate() {
                    // SAFETY: SSE2 is part of the x86_64 baseline.
                    out(i, unsafe { x86::sum_sse2(blocks, n) });
                }
            }
        }
    }
}

impl Kernel {
    /// For every normal `i` and lane `l`: `acc[i][ch][l] +=` the f32 sum over `blocks` of lane
    /// `l`'s terms `max(n . d, 0) w_ch` (the operations of [`Kernel::for_each_sum`], without a
    /// sum across lanes), converted to f64. Summing many tiles this way and the lanes once at
    /// the end ([`wide_total`]) costs two vector operations per tile and channel instead of a
    /// horizontal sum per tile, and is more accurate. The terms use fused multiply-adds (see
    /// `wide_scalar`). Bit-identical across kernels: AVX-512 takes two normals per pass, AVX with
    /// FMA one (two registers per component), `Sse2` and `Scalar` (and a kernel whose level the
    /// CPU lacks) the portable loop.
    pub fn accumulate_wide(self, blocks: &[WideBlock], normals: &[[f32; 3]], acc: &mut [WideSums]) {
        assert_eq!(normals.len(), acc.len(), "one accumulator per normal");
        #[cfg(target_arch = "x86_64")]
        {
            if self == Kernel::Avx512 && cpu::supports(Level::Avx512) {
                let mut pairs = normals.chunks_exact(2).zip(acc.chunks_exact_mut(2));
                for (p, a) in pairs.by_ref() {
                    let [a0, a1] = a else { unreachable!("chunks of 2") };
                    // SAFETY: the CPU has AVX-512 F and DQ (checked above).
                    unsafe { x86::wide2_avx512(blocks, p[0], p[1], [a0, a1]) };
                }
                if normals.len() % 2 == 1 {
                    // The unpaired last normal rides with itself (into a scratch copy).
                    let last = normals.len() - 1;
                    let mut scratch = acc[last];
                    // SAFETY: as above.
                    unsafe { x86::wide2_avx512(blocks, normals[last], normals[last], [&mut acc[last], &mut scratch]) };
                }
                return;
            }
            if matches!(self, Kernel::Avx | Kernel::Avx512) && cpu::supports(Level::Avx2) {
                for (n, a) in normals.iter().zip(acc.iter_mut()) {
                    // SAFETY: the CPU has AVX and FMA (level `avx2`, checked above).
                    unsafe { x86::wide1_avx(blocks, *n, a) };
                }
                return;
            }
        }
        for (n, a) in normals.iter().zip(acc.iter_mut()) {
            wide_scalar(blocks, *n, a);
        }
    }
}

/// A cone of directions around a unit `axis`, of half-angle `t` held as `cos t` and `sin t`
/// (`0 <= t < 90 deg`), for [culling](self#culling).
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    pub axis: DVec3,
    pub cos: f64,
    pub sin: f64,
}

impl Cone {
    /// The half-angle of a single direction: `cos 0 = 1`, `sin 0 = 0`.
    pub const RAY: (f64, f64) = (1.0, 0.0);

    /// A cone containing every direction of `dirs`, which must be unit vectors (to rounding):
    /// the axis is their normalised sum, the half-angle the largest angle to it (`cos t =
    /// min d . axis`, `sin t = sqrt(1 - cos^2 t)`). `None` when no such cone is narrower than
    /// a hemisphere: no directions, a sum that is zero or not finite (a NaN direction), or a
    /// direction at 90 degrees or more from the axis. A set without a cone is never culled.
    pub fn around(dirs: impl Iterator<Item = DVec3> + Clone) -> Option<Cone> {
        let sum = dirs.clone().fold(DVec3::ZERO, |s, d| s + d);
        let axis = unit(sum)?;
        let cos = dirs.map(|d| d.dot(axis)).fold(1.0f64, f64::min);
        (cos > 0.0).then(|| Cone { axis, cos, sin: (1.0 - cos * cos).max(0.0).sqrt() })
    }

    /// `Some(h)` when `self` (the normals) and a cone of lights of half-angle `b` (given as
    /// `(cos b, sin b)`, [`Cone::RAY`] for one light) are narrow enough for culling
    /// (`t + b < 90 deg`): then lights whose axis `a` has `axis . a <= h` are behind every
    /// normal, even in f32, with `h = -(sin(t + b) + CULL_MARGIN)` (see the module documentation).
    /// `None`: nothing can be culled.
    #[inline]
    pub fn cull_threshold(&self, spread: (f64, f64)) -> Option<f64> {
        self.threshold_with_margin(spread, CULL_MARGIN)
    }

    #[inline]
    fn threshold_with_margin(&self, (cos_b, sin_b): (f64, f64), margin: f64) -> Option<f64> {
        // cos(t + b) > 0  <=>  t + b < 90 deg
        if self.cos * cos_b - self.sin * sin_b > 0.0 {
            // sin(t + b); for b = 0 it is exactly sin t.
            Some(-(self.sin * cos_b + self.cos * sin_b + margin))
        } else {
            None
        }
    }

    /// True when every direction of `lights` is behind every direction of `self` (the
    /// normals): [`Cone::cull_threshold`] applied to the cosine between the axes.
    #[inline]
    pub fn hides(&self, lights: &Cone) -> bool {
        self.cull_threshold((lights.cos, lights.sin)).is_some_and(|h| self.axis.dot(lights.axis) <= h)
    }
}

#[cfg(test)]
mod tests;
