//! The row kernels of [`crate::values::Distribution2D`]: each writes one row's conditional CDF,
//! the normalised running sums of its texels (`S_x / sum`, exactly 0 first and exactly 1 from the
//! last non-zero texel on), and reports the row's sum and smallest texel so that the caller can
//! tell a row with a bad texel (NaN, an infinity, a negative) and redo it from a sanitised copy.
//!
//! Three kernels give the same bits ([`write_row`], one per [`crate::cpu`] level). The
//! portable one reads each row twice (it is in cache the second time) and writes its CDF once:
//! `row_sum` finds the row's sum (and, from the sum and the row's minimum, whether it holds a
//! bad texel), then `write_row_cdf` writes the normalised running sums directly, multiplying by
//! `1 / sum`. Both run over blocks of 8 texels so that only one f64 add per block is on the
//! dependency chain. The AVX-512 and AVX2 ones (`x86`, chosen at run time) write the running
//! sums once with an 8-lane scan per block and normalise them while the row is in the L1 cache,
//! so that memory traffic, not the scan, bounds `BuildCdf` (docs/src/benchmarks/point-targets.md, "Point targets", BuildCdf: the
//! kernels' cost per texel and the floor they are measured against). `values::distribution`'s tests compare every kernel the processor
//! has with the portable one, row by row and whole builds (`row_kernels_give_the_same_bits`).
//!
//! A leaf: it uses nothing of the crate but [`crate::cpu`], so the distribution (in `values`) can
//! build on it while `maths` builds on `values`.

use std::mem::MaybeUninit;

use crate::cpu::{self, Level};

/// Block `b` of 8 texels' own prefix sums, as a small tree that does not depend on the blocks
/// before it: `[v0, v0+v1, ..., v0+...+v7]` (non-decreasing for non-negative texels, and equal
/// from the last non-zero texel on).
#[inline(always)]
fn block_prefix(b: &[f32; 8]) -> [f64; 8] {
    let v: [f64; 8] = b.map(f64::from);
    let (p01, p23, p45, p67) = (v[0] + v[1], v[2] + v[3], v[4] + v[5], v[6] + v[7]);
    let (p03, p47) = (p01 + p23, p45 + p67);
    [v[0], p01, p01 + v[2], p03, p03 + v[4], p03 + p45, p03 + (p45 + v[6]), p03 + p47]
}

/// A row's running sums (as f64): `S_0 = 0` and, for texel `8k + i`, `S = C_k + L_k[i]` where
/// `L_k = block_prefix(block k)` and `C_{k+1} = C_k + L_k[7]` (texels past the last full block
/// are added one by one). Only one f64 add per 8 texels is on the dependency chain (a plain
/// running sum has one per texel, and its latency was the bottleneck). Every `S` is `C_k +` a
/// non-negative, non-decreasing local sum, so the sums are non-decreasing, a block ends exactly
/// on the next block's carry, and every sum after the last non-zero texel equals the row's sum
/// exactly. `row_sum` and `write_row_cdf` both evaluate this, with the same operations in the
/// same order, so the sum `write_row_cdf` is given is bit for bit its last running sum.
///
/// Returns `(sum, min)`, the row's sum and its smallest texel. The row is free of bad texels iff
/// `sum` is finite (no NaN and no +Inf: an f64 sum of finite f32 values cannot overflow) and
/// `min >= 0` (no negative and no -Inf; -0.0 passes and adds nothing).
fn row_sum(src: &[f32]) -> (f64, f32) {
    let mut carry = 0.0f64;
    // One minimum per lane, by compare-and-select: `f32::min`'s NaN rule made this loop much
    // slower (docs/src/benchmarks/point-targets.md, "BuildCdf at scale").
    let mut mins = [f32::INFINITY; 8];
    let mut blocks = src.chunks_exact(8);
    for b in &mut blocks {
        let b: &[f32; 8] = b.try_into().expect("8 texels");
        for (m, &x) in mins.iter_mut().zip(b) {
            *m = if x < *m { x } else { *m };
        }
        carry += block_prefix(b)[7];
    }
    let mut min = mins.iter().fold(f32::INFINITY, |m, &x| if x < m { x } else { m });
    for &x in blocks.remainder() {
        min = if x < min { x } else { min };
        carry += x as f64;
    }
    (carry, min)
}

/// Writes row `src`'s conditional CDF into `cdf` (`src.len() + 1` entries) in one pass, given
/// `sum = row_sum(src).0`: `S / sum` for each running sum `S` (see `row_sum`), exactly 1.0 where
/// `S == sum`, as the distribution's `normalise_cdf` does, but without first storing the sums and reading them back.
/// A zero (or non-finite) sum gives the uniform CDF. `cdf[0] = 0`, `cdf[n] = 1` exactly.
fn write_row_cdf<S: CdfSlot>(src: &[f32], sum: f64, cdf: &mut [S]) {
    let n = src.len();
    if !(sum > 0.0 && sum.is_finite()) {
        write_uniform_cdf(cdf);
    } else {
        let inv = 1.0 / sum;
        let norm = |s: f64| if s == sum { 1.0 } else { s * inv };
        let mut carry = 0.0f64;
        let mut blocks = src.chunks_exact(8);
        let mut out = cdf[1..].chunks_exact_mut(8);
        for (b, o) in (&mut blocks).zip(&mut out) {
            let b: &[f32; 8] = b.try_into().expect("8 texels");
            let local = block_prefix(b);
            let end = carry + local[7];
            if end == sum {
                // The block reaches the row's sum: entries equal to it become exactly 1.0.
                for (o, l) in o.iter_mut().zip(local) {
                    o.set(norm(carry + l));
                }
            } else {
                // Every entry is <= end < sum: no comparison needed (a quarter of the time).
                for (o, l) in o.iter_mut().zip(local) {
                    o.set((carry + l) * inv);
                }
            }
            carry = end;
        }
        for (&x, o) in blocks.remainder().iter().zip(out.into_remainder()) {
            carry += x as f64;
            o.set(norm(carry));
        }
    }
    cdf[0].set(0.0);
    cdf[n].set(1.0);
}

/// The uniform CDF `k / n` over `cdf.len() = n + 1` entries: a row of zero (or non-finite) sum.
fn write_uniform_cdf<S: CdfSlot>(cdf: &mut [S]) {
    let n = cdf.len() - 1;
    for (k, c) in cdf.iter_mut().enumerate() {
        c.set(k as f64 / n as f64);
    }
}

/// Writes row `src`'s conditional CDF into `cdf` (`src.len() + 1` slots) if the row is free of
/// bad texels, and returns `row_sum(src)`: `(sum, min)`. A row with a bad texel (`sum` not
/// finite or `min < 0`) leaves `cdf` partly written, for the caller to redo.
///
/// The kernel is `level`'s ([`cpu::usable`]: a level the processor lacks runs the widest it has),
/// and all give the same bits (a test compares them on rows of every length modulo 8, zero rows,
/// -0.0, huge dynamic ranges and bad texels); `Distribution2D::build` runs at [`cpu::level`]:
/// - portable: `row_sum`, then `write_row_cdf`: scalar code, every processor, the slowest (each
///   kernel's cost per texel: docs/src/benchmarks/point-targets.md, "BuildCdf at scale");
/// - AVX-512: `x86::write_row_cdf`, the same operations on 8 lanes (AVX-512F and DQ), the fastest;
/// - AVX2: `x86::write_row_cdf_avx2`, the same on two halves of 4 lanes, for the
///   processors without AVX-512.
#[inline]
pub(crate) fn write_row(level: Level, src: &[f32], cdf: &mut [MaybeUninit<f64>]) -> (f64, f32) {
    match cpu::usable(level) {
        // SAFETY (both arms): `cpu::usable` gave a level the processor has (the level alone
        // would not: any code in the crate can name it).
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { x86::write_row_cdf(src, cdf) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { x86::write_row_cdf_avx2(src, cdf) },
        _ => {
            let (sum, min) = row_sum(src);
            if sum.is_finite() && min >= 0.0 {
                write_row_cdf(src, sum, cdf);
            }
            (sum, min)
        }
    }
}

/// The rows' CDFs with AVX-512 or AVX2, written by hand because no crate does a scan with these
/// bits. `row_sum` and `write_row_cdf` are compiler-scheduled scalar code, bound by arithmetic
/// even on one row in the L1 cache; compiling them for AVX-512 made them slower, as the
/// compiler does not see that `block_prefix`'s tree is a scan. Here it is one: three shuffles and
/// adds per block of 8 texels, the same adds on the same values as the tree, so the bits are the
/// portable kernel's. The loop is bound by the shuffle unit (cross-lane shuffles: one a cycle),
/// so it spends as few as it can: zero-masked shuffles (AVX2: blends with zero) instead of
/// merges, the carry kept in every lane. docs/src/benchmarks/point-targets.md ("BuildCdf at scale") has each kernel's
/// cost per texel and the variants tried.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;
    use std::mem::MaybeUninit;

    /// `block_prefix` of the 8 lanes of `v`: lane pairs, then pairs of pairs, then halves (a
    /// Sklansky scan). Lane by lane the adds are the tree's: `[v0, v0+v1, (v0+v1)+v2,
    /// (v0+v1)+(v2+v3), p03+v4, p03+(v4+v5), p03+((v4+v5)+v6), p03+((v4+v5)+(v6+v7))]`.
    /// Each level adds a zero-masked shuffle to every lane (a merge-masked add made the compiler
    /// blend with a cross-lane shuffle, the scarce unit here, and was slower). The lanes that add
    /// +0.0 keep their value, except that -0.0 becomes +0.0, which changes no running sum: the
    /// carry a block's lanes are added to is never -0.0 (it starts at +0.0 and +0.0 + -0.0 is
    /// +0.0), so `carry + lane` is the same either way; lane 7, the block's total, is made of
    /// the tree's adds only.
    #[inline(always)]
    unsafe fn block_prefix(v: __m512d) -> __m512d {
        let v = _mm512_add_pd(v, _mm512_maskz_movedup_pd(0b1010_1010, v));
        let v = _mm512_add_pd(v, _mm512_maskz_permutex_pd::<0b01_01_01_01>(0b1100_1100, v));
        _mm512_add_pd(v, _mm512_maskz_permutexvar_pd(0b1111_0000, _mm512_set1_epi64(3), v))
    }

    /// `write_row` (level `avx512`) in two passes over the row's CDF, which stays in the L1 cache
    /// between them (16 KiB at 2048 texels): the running sums, with the row's minimum, and then,
    /// when the row is good, their normalisation (`finish_row`). Unlike the portable kernel it
    /// reads the texels once and has one dependency chain (the carry's f64 add per block)
    /// instead of two. Two rows interleaved, for two independent chains, gained little (the
    /// chain is not what bounds it) and were not kept.
    ///
    /// # Safety
    /// The processor must have AVX-512F and DQ.
    #[target_feature(enable = "avx512f,avx512dq")]
    pub(super) unsafe fn write_row_cdf(src: &[f32], cdf: &mut [MaybeUninit<f64>]) -> (f64, f32) {
        let n = src.len();
        assert_eq!(cdf.len(), n + 1, "a row's CDF has one entry more than the row");
        let blocks = n / 8;
        let out = cdf.as_mut_ptr().cast::<f64>();
        let seven = _mm512_set1_epi64(7);
        // The carry in every lane: adding lane 7 broadcast (one shuffle) instead of moving it to
        // a scalar and back (three); the same add, so the same bits.
        let mut carry = _mm512_setzero_pd();
        let mut mins = _mm256_set1_ps(f32::INFINITY);
        for k in 0..blocks {
            // SAFETY (this block): texels 8k..8k+8 are inside `src` (k < n / 8), and entries
            // 8k+1..8k+9 inside `cdf` (n + 1 entries); unaligned loads and stores.
            let x = _mm256_loadu_ps(src.as_ptr().add(8 * k));
            // `x < min ? x : min` per lane, as `row_sum` (a NaN texel leaves the minimum).
            mins = _mm256_min_ps(x, mins);
            let local = block_prefix(_mm512_cvtps_pd(x));
            _mm512_storeu_pd(out.add(1 + 8 * k), _mm512_add_pd(carry, local));
            carry = _mm512_add_pd(carry, _mm512_permutexvar_pd(seven, local));
        }
        finish_row(src, cdf, 8 * blocks, _mm512_cvtsd_f64(carry), lane_min(mins))
    }

    /// The smallest of the 8 per-lane minima, folded in lane order as `row_sum` does.
    #[inline(always)]
    unsafe fn lane_min(mins: __m256) -> f32 {
        let mut lanes = [0.0f32; 8];
        _mm256_storeu_ps(lanes.as_mut_ptr(), mins);
        lanes.iter().fold(f32::INFINITY, |m, &x| if x < m { x } else { m })
    }

    /// The rest of a row after its first `done` texels: their running sums, then, for a good
    /// row, the normalisation of all of them: `S == sum` gives exactly 1.0, else `S (1 / sum)`,
    /// as `write_row_cdf`; a zero sum gives the uniform CDF. A bad row (`sum` not finite or
    /// `min < 0`) is left for the caller to redo. Scalar code, inlined into each kernel, where
    /// the compiler vectorises the normalisation for that kernel's instruction set (as fast as
    /// the same loop written with AVX-512 intrinsics).
    ///
    /// # Safety
    /// `cdf` (`src.len() + 1` entries) must hold the running sums of the first `done` texels at
    /// 1..=done.
    #[inline(always)]
    unsafe fn finish_row(
        src: &[f32],
        cdf: &mut [MaybeUninit<f64>],
        done: usize,
        mut carry: f64,
        mut min: f32,
    ) -> (f64, f32) {
        let n = src.len();
        let out = cdf.as_mut_ptr().cast::<f64>();
        for (i, &x) in src.iter().enumerate().skip(done) {
            min = if x < min { x } else { min };
            carry += x as f64;
            out.add(i + 1).write(carry);
        }
        let sum = carry;
        if !(sum.is_finite() && min >= 0.0) {
            return (sum, min);
        }
        if !(sum > 0.0) {
            super::write_uniform_cdf(cdf);
            return (sum, min);
        }
        let inv = 1.0 / sum;
        // SAFETY: entries 1..=n are inside `cdf` and were written above or before the call.
        let sums = std::slice::from_raw_parts_mut(out.add(1), n);
        for s in sums.iter_mut() {
            *s = if *s == sum { 1.0 } else { *s * inv };
        }
        out.write(0.0);
        out.add(n).write(1.0);
        (sum, min)
    }

    /// `write_row_cdf` with AVX2: each block as two halves of 4 lanes. Lanes 0-3 take levels 1
    /// and 2 of the scan, lanes 4-7 the same plus lane 3 of the first half (level 3), so every
    /// lane adds what the AVX-512 lane adds; blends with +0.0 stand in for zero-masking (the same
    /// values, -0.0 included: see `block_prefix`).
    ///
    /// # Safety
    /// The processor must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn write_row_cdf_avx2(src: &[f32], cdf: &mut [MaybeUninit<f64>]) -> (f64, f32) {
        let n = src.len();
        assert_eq!(cdf.len(), n + 1, "a row's CDF has one entry more than the row");
        let blocks = n / 8;
        let out = cdf.as_mut_ptr().cast::<f64>();
        let zero = _mm256_setzero_pd();
        let mut carry = _mm256_setzero_pd();
        let mut mins = _mm256_set1_ps(f32::INFINITY);
        for k in 0..blocks {
            // SAFETY: as in `write_row_cdf`: texels 8k..8k+8 and entries 8k+1..8k+9 are inside.
            let x = _mm256_loadu_ps(src.as_ptr().add(8 * k));
            mins = _mm256_min_ps(x, mins);
            let lo = _mm256_cvtps_pd(_mm256_castps256_ps128(x));
            let hi = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(x));
            let lo = _mm256_add_pd(lo, _mm256_blend_pd::<0b1010>(zero, _mm256_movedup_pd(lo)));
            let hi = _mm256_add_pd(hi, _mm256_blend_pd::<0b1010>(zero, _mm256_movedup_pd(hi)));
            let lo = _mm256_add_pd(lo, _mm256_blend_pd::<0b1100>(zero, _mm256_permute4x64_pd::<0b01_01_01_01>(lo)));
            let hi = _mm256_add_pd(hi, _mm256_blend_pd::<0b1100>(zero, _mm256_permute4x64_pd::<0b01_01_01_01>(hi)));
            let hi = _mm256_add_pd(hi, _mm256_permute4x64_pd::<0b11_11_11_11>(lo));
            _mm256_storeu_pd(out.add(1 + 8 * k), _mm256_add_pd(carry, lo));
            _mm256_storeu_pd(out.add(5 + 8 * k), _mm256_add_pd(carry, hi));
            carry = _mm256_add_pd(carry, _mm256_permute4x64_pd::<0b11_11_11_11>(hi));
        }
        finish_row(src, cdf, 8 * blocks, _mm256_cvtsd_f64(carry), lane_min(mins))
    }
}

/// Where `write_row_cdf` writes: an initialised `f64`, or the not yet initialised capacity of
/// the CDF buffer (`Distribution2D::build` writes every entry of every row before the buffer's
/// length covers them, so the buffer is never zeroed first: at 2048x1024 zeroing its 16 MiB was a
/// third of the build).
trait CdfSlot {
    fn set(&mut self, value: f64);
}

impl CdfSlot for f64 {
    #[inline(always)]
    fn set(&mut self, value: f64) {
        *self = value;
    }
}

impl CdfSlot for MaybeUninit<f64> {
    #[inline(always)]
    fn set(&mut self, value: f64) {
        self.write(value);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::sampling::sequences::SplitMix64;
    use crate::values::distribution::tests::random_map;
    use crate::values::{Distribution2D, Image};

    #[test]
    fn row_cdfs_are_monotone_and_end_on_exactly_one() {
        let mut rng = SplitMix64::new(5);
        for n in [1usize, 2, 7, 8, 9, 16, 17, 100] {
            for trailing in [0, 1, 3, 9] {
                let mut src: Vec<f32> = (0..n).map(|_| 0.01 + rng.next_f64() as f32).collect();
                // Trailing zeros (one of them -0.0) after the last non-zero texel.
                let last = n.saturating_sub(trailing).max(1);
                for v in &mut src[last..] {
                    *v = -0.0;
                }
                let (sum, min) = row_sum(&src);
                let serial: f64 = src.iter().map(|&v| v as f64).sum();
                assert!((sum - serial).abs() <= 1e-15 * serial, "{n}: {sum} vs {serial}");
                assert!(min >= 0.0);
                let mut cdf = vec![f64::NAN; n + 1];
                write_row_cdf(&src, sum, &mut cdf);
                assert_eq!((cdf[0], cdf[n]), (0.0, 1.0));
                assert!(cdf.windows(2).all(|p| p[0] <= p[1]), "{n}: {cdf:?}");
                assert!(cdf[last..].iter().all(|&c| c == 1.0), "{n} {trailing}: {cdf:?}");
                assert!(cdf[..last].iter().all(|&c| c < 1.0), "{n} {trailing}: {cdf:?}");
                let mut prefix = 0.0f64;
                for (x, &v) in src.iter().enumerate() {
                    prefix += v as f64;
                    assert!((cdf[x + 1] - prefix / serial).abs() <= 4.0 * f64::EPSILON, "{n}: entry {x}");
                }
            }
        }
        let mut zero = vec![f64::NAN; 5];
        write_row_cdf(&[0.0; 4], 0.0, &mut zero);
        assert_eq!(zero, [0.0, 0.25, 0.5, 0.75, 1.0]);
        let mut src = vec![1.0f32; 10];
        src[9] = -1.0;
        assert!(row_sum(&src).1 < 0.0);
        src[9] = f32::NAN;
        assert!(!row_sum(&src).0.is_finite());
        src[9] = f32::INFINITY;
        assert!(!row_sum(&src).0.is_finite());
        src[9] = f32::NEG_INFINITY;
        assert!(row_sum(&src).1 < 0.0);
    }

    /// The row kernel of every level the processor has gives the portable kernel's bits: every
    /// row length modulo 8, zero rows, a 1e30 sun beside 1e-3 sky, subnormals, f32::MAX, and bad
    /// texels (the same error, or with `sanitize` the same distribution).
    #[test]
    fn row_kernels_give_the_same_bits() {
        let levels = cpu::tested_levels();
        let mut maps = Vec::new();
        for w in (1..=41).chain([2048, 2051]) {
            maps.push(random_map(w, 5, w as u64, Some(2)));
            let mut rng = SplitMix64::new(100 + w as u64);
            let data = (0..w * 4)
                .map(|i| match rng.next_u64() % 8 {
                    0 => 1e30,
                    1 => 1e-3,
                    2 => f32::MIN_POSITIVE / 8.0,
                    3 => f32::MAX,
                    4 if i % 3 == 0 => -0.0,
                    _ => (1e6 * rng.next_f64() * rng.next_f64()) as f32,
                })
                .collect();
            maps.push(Image::from_vec(w, 4, 1, data));
        }
        // -0.0: a whole row, a first block, a tail, one texel in a block of positives.
        for w in [3, 8, 13, 2051] {
            let mut img = random_map(w, 4, 11, None);
            img.data[..w].fill(-0.0);
            img.data[w..w + w.min(8)].fill(-0.0);
            img.data[3 * w - 1] = -0.0;
            img.data[3 * w + w / 2] = -0.0;
            maps.push(img);
        }
        let clean_maps = maps.len();
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0] {
            for w in [7, 8, 9, 23, 2051] {
                let mut img = random_map(w, 3, 9, None);
                img.data[w + w / 2] = bad;
                maps.push(img);
                // In the tail after the last full block.
                let mut img = random_map(w, 3, 10, None);
                img.data[2 * w - 1] = bad;
                maps.push(img);
            }
        }
        // Row by row: the same (sum, min) bits, and for a good row the same entries; a map
        // without bad texels has only good rows (so `build_with` never redoes a row that the
        // SIMD kernel wrongly called bad, which the comparison of whole builds would hide).
        for (i, img) in maps.iter().enumerate() {
            let w = img.width;
            for y in 0..img.height {
                // SAFETY (reads below): every slot is initialised (to NaN) before a kernel writes.
                let bits =
                    |r: &[MaybeUninit<f64>]| r.iter().map(|e| unsafe { e.assume_init() }.to_bits()).collect::<Vec<_>>();
                let mut portable = vec![MaybeUninit::new(f64::NAN); w + 1];
                let (sum, min) = write_row(Level::Portable, img.row(y), &mut portable);
                let good = sum.is_finite() && min >= 0.0;
                assert!(good || i >= clean_maps, "map {i} row {y} has no bad texel");
                for &level in &levels[1..] {
                    let mut row = vec![MaybeUninit::new(f64::NAN); w + 1];
                    let (s, m) = write_row(level, img.row(y), &mut row);
                    assert_eq!(
                        (s.to_bits(), m.to_bits()),
                        (sum.to_bits(), min.to_bits()),
                        "{level} {w}x{} row {y}",
                        img.height
                    );
                    if good {
                        assert_eq!(bits(&row), bits(&portable), "{level} {w}x{} row {y}", img.height);
                    }
                }
            }
        }
        for img in &maps {
            for (sin_theta, sanitize) in [(true, false), (false, false), (true, true)] {
                for &level in &levels[1..] {
                    let portable = Distribution2D::build_with(img, sin_theta, sanitize, Level::Portable);
                    let simd = Distribution2D::build_with(img, sin_theta, sanitize, level);
                    match (portable, simd) {
                        (Ok(a), Ok(b)) => {
                            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                            assert_eq!(
                                bits(&a.conditional_cdf),
                                bits(&b.conditional_cdf),
                                "{}x{}",
                                img.width,
                                img.height
                            );
                            assert_eq!(bits(&a.row_sums), bits(&b.row_sums));
                            assert_eq!(a, b);
                        }
                        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                        (a, b) => panic!("{level} {}x{}: {a:?} against {b:?}", img.width, img.height),
                    }
                }
            }
        }
    }
}
