//! The 8-bit sRGB code of a linear value: [`linear_to_srgb8`], the exact function (the OETF
//! of IEC 61966-2-1, formula in `super::png`), and [`Srgb8Table`], the same code by table,
//! without its `powf` for most values.
//!
//! The code is a non-decreasing step function of `c`, so it is the number of steps at or below
//! `c`: `T[k - 1]`, k = 1..=255, is the smallest f64 whose code is at least k, found once by
//! bisection over the bit patterns of [0, 1) (ordered as the values are) with the exact function
//! itself. A lookup is a binary search over the 255 steps; a value within `GUARD` (relative) of
//! a step takes the exact function instead. Why the table is exact elsewhere: a value could get
//! another code than its step count only if the computed `V * 255` were on the other side of a
//! rounding boundary `k - 1/2` than the true one, i.e. within the computation's error of it. On
//! the linear segment (c <= 0.0031308, `V * 255` <= 10.4) that error is below 1e-14 and the slope
//! of `V * 255` in ln c is at least 0.33 above the first step (c = 1.5e-4), so a value outside
//! the guard band is at least 0.33 GUARD = 3e-13 from a boundary; on the power segment the error
//! is below 1e-13 (a few ulps of 255) and the slope at least 10, so at least 9e-12. The tests
//! compare both functions on 20,000 values on each side of every step, on a stride of all f32
//! in [0, 1], and on values times random exposures. Measured: docs/src/benchmarks/engine.md, "Peak memory".

use std::sync::OnceLock;

/// Linear value -> 8-bit sRGB code (IEC 61966-2-1 OETF, clamped, NaN -> 0).
#[inline]
pub fn linear_to_srgb8(c: f64) -> u8 {
    if !(c > 0.0) {
        return 0; // negative, zero, NaN
    }
    if c >= 1.0 {
        return 255; // includes +Inf
    }
    let v = if c <= 0.0031308 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Relative distance to a step below which the exact function decides.
const GUARD: f64 = 1.0 / (1u64 << 40) as f64;

/// `T[k - 1]`: the smallest f64 whose code is at least k (see the module documentation).
fn steps() -> &'static [f64; 255] {
    static STEPS: OnceLock<[f64; 255]> = OnceLock::new();
    STEPS.get_or_init(|| {
        let mut t = [0.0; 255];
        for (i, step) in t.iter_mut().enumerate() {
            let k = i as u8 + 1;
            // The code of 0 is 0 and of 1.0 is 255: bisect between their bit patterns.
            let (mut lo, mut hi) = (0u64, 1.0f64.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if linear_to_srgb8(f64::from_bits(mid)) >= k {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *step = f64::from_bits(hi);
        }
        t
    })
}

/// A lookup table of the steps, taken once per image (a `&` to the table built on first use).
#[derive(Clone, Copy)]
pub struct Srgb8Table(&'static [f64; 255]);

impl Srgb8Table {
    pub fn new() -> Srgb8Table {
        Srgb8Table(steps())
    }

    /// The code of `c`: `linear_to_srgb8(c)`, bit for bit.
    #[inline]
    pub fn code(self, c: f64) -> u8 {
        if !(c > 0.0) {
            return 0; // negative, zero, NaN
        }
        if c >= 1.0 {
            return 255; // includes +Inf
        }
        let t = self.0;
        let k = t.partition_point(|&s| s <= c);
        let near = |s: f64| (c - s).abs() <= s * GUARD;
        if (k > 0 && near(t[k - 1])) || (k < t.len() && near(t[k])) {
            return linear_to_srgb8(c);
        }
        k as u8
    }
}

impl Default for Srgb8Table {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn known_values() {
        assert_eq!(linear_to_srgb8(0.5), 188);
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(7.0), 255);
        assert_eq!(linear_to_srgb8(f64::NAN), 0);
        assert_eq!(linear_to_srgb8(f64::INFINITY), 255);
        assert_eq!(linear_to_srgb8(-3.0), 0);
        assert_eq!(linear_to_srgb8(0.001), 3); // linear segment: 12.92 * 0.001 * 255 = 3.29
    }

    #[test]
    fn the_steps_are_where_the_exact_code_steps() {
        let t = steps();
        for (i, &s) in t.iter().enumerate() {
            let k = i as u8 + 1;
            assert!(linear_to_srgb8(s) >= k && linear_to_srgb8(f64::from_bits(s.to_bits() - 1)) < k, "step {k}");
        }
        assert!(t.windows(2).all(|w| w[0] < w[1]));
        assert!(t[0] > 1e-4, "the module's bound on the slope assumes it: {}", t[0]);
    }

    #[test]
    fn the_table_gives_the_exact_code_next_to_every_step() {
        let table = Srgb8Table::new();
        for &s in steps() {
            let bits = s.to_bits();
            for d in 0..20_000u64 {
                for c in [f64::from_bits(bits + d), f64::from_bits(bits - d)] {
                    assert_eq!(table.code(c), linear_to_srgb8(c), "{c:e}");
                }
            }
            // And at the edges of the guard band, on both sides.
            for c in [s * (1.0 + GUARD), s * (1.0 - GUARD), s * (1.0 + 2.0 * GUARD), s * (1.0 - 2.0 * GUARD)] {
                assert_eq!(table.code(c), linear_to_srgb8(c), "{c:e}");
            }
        }
    }

    /// How many f32 among every `stride`-th bit pattern in [0, 1] get another code by table.
    fn mismatches_in_0_1(stride: u32) -> usize {
        let table = Srgb8Table::new();
        let end = 1.0f32.to_bits() + 8;
        (0..end / stride + 1)
            .into_par_iter()
            .map(|i| f32::from_bits(i * stride) as f64)
            .filter(|&c| table.code(c) != linear_to_srgb8(c))
            .count()
    }

    #[test]
    fn the_table_gives_the_exact_code_on_a_stride_of_all_f32_in_0_1() {
        assert_eq!(mismatches_in_0_1(7), 0);
    }

    /// Every f32 in [0, 1] (1.07e9 values; seconds in a release build on 2 cores; the table's
    /// speed against the exact function: `cargo bench --bench srgb8`).
    #[test]
    fn the_table_gives_the_exact_code_on_every_f32_in_0_1() {
        assert_eq!(mismatches_in_0_1(1), 0);
    }

    #[test]
    fn the_table_gives_the_exact_code_under_any_exposure() {
        use crate::maths::sampling::sequences::SplitMix64;
        let table = Srgb8Table::new();
        let mut rng = SplitMix64::new(7);
        for _ in 0..2_000_000 {
            let s = rng.next_f64() as f32 * 2.0;
            let gain = (rng.next_f64() * 40.0 - 20.0).exp2();
            let c = s as f64 * gain;
            assert_eq!(table.code(c), linear_to_srgb8(c), "{s} x {gain}");
        }
        for c in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0, 0.0, 1.0, 1e-300, -1e-300, f64::MIN_POSITIVE] {
            assert_eq!(table.code(c), linear_to_srgb8(c), "{c:e}");
        }
    }
}
