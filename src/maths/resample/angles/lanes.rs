//! [`super::latlong_angles`] of many directions at once: the grid points of a rotated lat-long
//! map's rows (`maths::resample::cut_cells`), four lanes at a time with AVX2 where the processor
//! has it (`crate::cpu`'s run-time level), else one at a time.
//!
//! The lanes do the scalar code's IEEE operations in its order (`x * x + z * z`, the square root,
//! the division `lo / hi`, `(a - 1) / (a + 1)`, the polynomial's multiply then add, no fused
//! multiply-add), and its branches as blends of both sides, so every level gives the same bits
//! (tested). A lane whose vector is zero or not finite (libm's `atan2` in the scalar code) is
//! redone by the scalar code.

use crate::cpu::{self, Level};

/// `(theta, phi)` of each direction of `dirs` into `out` (the same length), the bits of
/// [`super::latlong_angles`], at `level` (lowered to what the processor has).
pub fn latlong_angles_into(level: Level, dirs: &[[f64; 3]], out: &mut [(f64, f64)]) {
    assert_eq!(dirs.len(), out.len(), "one angle pair a direction");
    #[cfg(target_arch = "x86_64")]
    if cpu::usable(level) >= Level::Avx2 {
        // SAFETY: `cpu::usable` gave a level the processor has, which includes AVX2.
        return unsafe { avx2::angles(dirs, out) };
    }
    let _ = cpu::usable(level);
    portable(dirs, out);
}

fn portable(dirs: &[[f64; 3]], out: &mut [(f64, f64)]) {
    for (o, &d) in out.iter_mut().zip(dirs) {
        *o = super::latlong_angles(d);
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

    use super::super::{P, TAN_PI_8};

    /// `super::super::atan2` in four lanes, and the lanes where it is valid (`hi` positive and
    /// finite: all bits set).
    #[inline]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn atan2(y: __m256d, x: __m256d) -> (__m256d, __m256d) {
        let sign = _mm256_set1_pd(-0.0);
        let (ax, ay) = (_mm256_andnot_pd(sign, x), _mm256_andnot_pd(sign, y));
        let swap = _mm256_cmp_pd::<_CMP_GT_OQ>(ay, ax);
        // `if ay > ax { (ax, ay) } else { (ay, ax) }`.
        let lo = _mm256_blendv_pd(ay, ax, swap);
        let hi = _mm256_blendv_pd(ax, ay, swap);
        let valid = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GT_OQ>(hi, _mm256_setzero_pd()),
            _mm256_cmp_pd::<_CMP_LT_OQ>(hi, _mm256_set1_pd(f64::INFINITY)),
        );
        let one = _mm256_set1_pd(1.0);
        let a = _mm256_div_pd(lo, hi);
        let big = _mm256_cmp_pd::<_CMP_GT_OQ>(a, _mm256_set1_pd(TAN_PI_8));
        let t = _mm256_blendv_pd(a, _mm256_div_pd(_mm256_sub_pd(a, one), _mm256_add_pd(a, one)), big);
        let x2 = _mm256_mul_pd(t, t);
        let mut p = _mm256_set1_pd(P[10]);
        for &c in P[..10].iter().rev() {
            p = _mm256_add_pd(_mm256_mul_pd(p, x2), _mm256_set1_pd(c));
        }
        let r = _mm256_mul_pd(t, p);
        let r = _mm256_blendv_pd(r, _mm256_add_pd(_mm256_set1_pd(FRAC_PI_4), r), big);
        let r = _mm256_blendv_pd(r, _mm256_sub_pd(_mm256_set1_pd(FRAC_PI_2), r), swap);
        let negative_x = _mm256_cmp_pd::<_CMP_LT_OQ>(x, _mm256_setzero_pd());
        let r = _mm256_blendv_pd(r, _mm256_sub_pd(_mm256_set1_pd(PI), r), negative_x);
        // `-r` where y's sign bit is set.
        (_mm256_xor_pd(r, _mm256_and_pd(y, sign)), valid)
    }

    /// `super::latlong_angles_into` with AVX2.
    ///
    /// # Safety
    /// The processor must have AVX and AVX2.
    #[target_feature(enable = "avx,avx2")]
    pub(super) unsafe fn angles(dirs: &[[f64; 3]], out: &mut [(f64, f64)]) {
        let n = dirs.len().min(out.len());
        let blocks = n / 4;
        let (zero, tau) = (_mm256_setzero_pd(), _mm256_set1_pd(TAU));
        for k in 0..blocks {
            let d = &dirs[4 * k..4 * k + 4];
            let x = _mm256_setr_pd(d[0][0], d[1][0], d[2][0], d[3][0]);
            let y = _mm256_setr_pd(d[0][1], d[1][1], d[2][1], d[3][1]);
            let z = _mm256_setr_pd(d[0][2], d[1][2], d[2][2], d[3][2]);
            let rho = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(z, z)));
            let (theta, valid_t) = atan2(rho, y);
            let (phi, valid_p) = atan2(_mm256_xor_pd(x, _mm256_set1_pd(-0.0)), z);
            // `if phi < 0 { phi += TAU }`, then `if phi >= TAU { phi = 0 }`.
            let phi = _mm256_blendv_pd(phi, _mm256_add_pd(phi, tau), _mm256_cmp_pd::<_CMP_LT_OQ>(phi, zero));
            let phi = _mm256_blendv_pd(phi, zero, _mm256_cmp_pd::<_CMP_GE_OQ>(phi, tau));
            let (mut t, mut p) = ([0.0; 4], [0.0; 4]);
            _mm256_storeu_pd(t.as_mut_ptr(), theta);
            _mm256_storeu_pd(p.as_mut_ptr(), phi);
            let valid = _mm256_movemask_pd(_mm256_and_pd(valid_t, valid_p));
            for i in 0..4 {
                out[4 * k + i] = if valid & (1 << i) != 0 { (t[i], p[i]) } else { super::super::latlong_angles(d[i]) };
            }
        }
        super::portable(&dirs[4 * blocks..n], &mut out[4 * blocks..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_gives_the_scalar_bits() {
        let mut rng = crate::maths::sampling::sequences::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.next_f64() * 2.0 - 1.0;
        let mut dirs: Vec<[f64; 3]> = (0..4001)
            .map(|i| {
                let near = if i % 5 == 0 { 1e-9 } else { 1.0 };
                [next() * near, next(), next() * near]
            })
            .collect();
        // The axes, signed zeros, a zero vector, and non-finite ones (the scalar fallback).
        for d in [
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [-0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [-0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, -0.0],
            [0.0; 3],
            [-0.0, -0.0, -0.0],
            [f64::NAN, 1.0, 0.0],
            [f64::INFINITY, 0.0, 1.0],
            [1.0, f64::NEG_INFINITY, 1.0],
        ] {
            dirs.push(d);
        }
        let want: Vec<_> = dirs.iter().map(|&d| crate::maths::resample::angles::latlong_angles(d)).collect();
        for level in cpu::tested_levels() {
            let mut got = vec![(0.0, 0.0); dirs.len()];
            latlong_angles_into(level, &dirs, &mut got);
            for ((g, w), d) in got.iter().zip(&want).zip(&dirs) {
                let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
                assert!(same(g.0, w.0) && same(g.1, w.1), "{level}: {d:?}: {g:?} vs {w:?}");
            }
        }
    }
}
