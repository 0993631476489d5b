//! The four image metrics of the lighting-estimation sphere protocol (StyleLight, EMLight,
//! DiffusionLight), exactly as `stylelight/fast_rmse.py` of `DiffusionLight/DiffusionLight-evaluation`
//! (MIT) defines them, over the `N` pixels of a mask and the first three channels, sums in f64:
//!
//! - `rmse = sqrt(sum_{masked px, c} (p - g)^2 / N)`: note `N` counts pixels, not pixels x 3;
//! - `si_rmse = sqrt((4ac - b^2) / (4a) / N)` with `a = sum p^2`, `b = -2 sum p g`,
//!   `c = sum g^2`: the RMSE after the closed-form best scale `alpha = -b / 2a` of the
//!   prediction. Computed as `(c - (sum p g)^2 / a) / N`, clamped at 0 (rounding can make it a
//!   hair negative, where the script's square root gives NaN). An all-zero prediction (`a = 0`)
//!   has no best scale; the script returns NaN there, this returns `sqrt(c / N)`, the limit
//!   (every scale of a zero image gives that error);
//! - `angular_error_deg`: the mean over the `N` pixels of `acos(clip(p . g / (|p| |g|), 0, 1))`
//!   in degrees; a pixel where `p` or `g` is black contributes 0 (the script's `nan_to_num`);
//! - `norm_rmse`: `rmse` after normalising each image by its own `0.01` and `99.9` percentiles
//!   (`(x - P0.01) / (P99.9 - P0.01)` over all pixels and the three channels, mask or not, numpy's
//!   linear interpolation between order statistics: ExpandNet's normalisation). An image whose
//!   two percentiles are equal normalises to 0 (the script divides by zero).
//!
//! Pixels where the prediction or the truth is not finite are left out of every sum and of `N`,
//! counted as `nonfinite_pixels` (the script would average NaN into every metric); `norm_rmse`'s
//! percentiles are taken over the finite samples. `tests/evaluation_metrics.rs` checks all four
//! against the script's own functions on the same EXR files to 1e-6 relative.

/// The protocol's metrics of one prediction against its truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProtocolMetrics {
    pub rmse: f64,
    pub si_rmse: f64,
    pub angular_error_deg: f64,
    pub norm_rmse: f64,
    /// `N`: the masked pixels with finite values in both images.
    pub pixels: usize,
    /// Masked pixels left out because a value of either image is NaN or infinite.
    pub nonfinite_pixels: usize,
}

/// Interleaved RGB-like samples: `data` has `channels >= 3` values per pixel; the first three count.
pub struct Pixels<'a> {
    pub data: &'a [f32],
    pub channels: usize,
}

impl Pixels<'_> {
    fn rgb(&self, i: usize) -> [f64; 3] {
        let p = &self.data[i * self.channels..];
        [p[0] as f64, p[1] as f64, p[2] as f64]
    }
    fn len(&self) -> usize {
        self.data.len() / self.channels
    }
}

/// numpy's `np.percentile(x, q)` (linear interpolation) of the finite first-three-channel samples.
pub fn numpy_percentile(samples: &mut [f64], q: f64) -> Option<f64> {
    let n = samples.len();
    if n == 0 {
        return None;
    }
    let pos = q / 100.0 * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    let t = pos - lo as f64;
    let (_, &mut a, rest) = samples.select_nth_unstable_by(lo, f64::total_cmp);
    // The next order statistic is the smallest of the values above the lo-th.
    let b = if hi == lo { a } else { rest.iter().copied().fold(f64::INFINITY, f64::min) };
    // numpy's `_lerp`: from the nearer end, so t = 0 and t = 1 give the order statistics exactly.
    Some(if t >= 0.5 { b - (b - a) * (1.0 - t) } else { a + (b - a) * t })
}

/// A key whose unsigned order is `f32::total_cmp`'s (the sign bit flipped for positives, every
/// bit for negatives), so that the heaps below compare integers. Without a branch, so that a
/// block's keys vectorise.
fn order_key(x: f32) -> u32 {
    let b = x.to_bits();
    b ^ (((b as i32) >> 31) as u32 | (1 << 31))
}

fn from_order_key(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

/// The samples the percentiles are taken over: the finite values among the first three (or
/// fewer) channels of each pixel of `data`, `channels` values a pixel.
#[derive(Clone, Copy)]
struct Samples<'a> {
    data: &'a [f32],
    channels: usize,
}

/// Pixels in a block of [`Samples`]: a block none of whose values could enter a full heap is
/// passed over after one minimum of its values' heap keys (alpha included, which only loosens the
/// test), so that a sphere render's background (most of its pixels, zeros) costs a vectorised
/// sweep instead of a heap comparison a sample.
const BLOCK: usize = 16;

impl Samples<'_> {
    fn each(&self, mut f: impl FnMut(f32)) {
        let take = self.channels.min(3);
        for px in self.data.chunks_exact(self.channels.max(1)) {
            px[..take].iter().filter(|x| x.is_finite()).for_each(|&x| f(x));
        }
    }

    fn count(&self) -> usize {
        let mut n = 0;
        self.each(|_| n += 1);
        n
    }
}

/// numpy's `np.percentile(x, q)` of the `n` values of `samples` (their count), as
/// [`numpy_percentile`] gives it, from the two order statistics around the rank kept in a bounded
/// heap of the values nearest the closer end: for the normaliser's 0.01 and 99.9 that heap holds
/// 0.1% of them, and a pass is at most one comparison a value instead of a selection over a copy
/// of all (the metrics' cost, before). Falls back to [`numpy_percentile`] when the heap would hold
/// over 1/64 of them.
fn percentile_of(n: usize, q: f64, samples: Samples) -> Option<f64> {
    if n == 0 {
        return None;
    }
    let pos = q / 100.0 * (n - 1) as f64;
    let lo = (pos.floor() as usize).min(n - 1);
    let hi = (lo + 1).min(n - 1);
    let t = pos - lo as f64;
    let (a, b) = if hi < n / 64 {
        // Ranks hi and lo among the smallest.
        let [b, a] = farthest_two_of_nearest(hi + 1, samples, End::Smallest);
        (if hi == lo { b } else { a }, b)
    } else if n - lo <= n / 64 {
        // Ranks lo and hi are the (n - lo)-th and (n - hi)-th largest.
        let [a, b] = farthest_two_of_nearest(n - lo, samples, End::Largest);
        (a, if hi == lo { a } else { b })
    } else {
        let mut v = Vec::with_capacity(n);
        samples.each(|x| v.push(x as f64));
        return numpy_percentile(&mut v, q);
    };
    let (a, b) = (a as f64, b as f64);
    Some(if t >= 0.5 { b - (b - a) * (1.0 - t) } else { a + (b - a) * t })
}

/// The end of the order a heap keeps the values nearest.
#[derive(Clone, Copy, PartialEq)]
enum End {
    Smallest,
    Largest,
}

impl End {
    /// The heap's key: unsigned order is `f32::total_cmp`'s, reversed towards the largest, so the
    /// max-heap's top is the kept value farthest from the end.
    fn key(self, x: f32) -> u32 {
        match self {
            End::Smallest => order_key(x),
            End::Largest => !order_key(x),
        }
    }

    fn value(self, k: u32) -> f32 {
        match self {
            End::Smallest => from_order_key(k),
            End::Largest => from_order_key(!k),
        }
    }

    /// Whether no value of `block` can enter a full heap whose top key is `top`: a value enters
    /// only with a key below the top's. (A NaN in the block, which is no sample, can only keep
    /// the block from being passed over.)
    fn passes_over(self, block: &[f32], top: u32) -> bool {
        block.iter().fold(u32::MAX, |m, &x| m.min(self.key(x))) >= top
    }
}

/// Of the `k` values of `samples` nearest `end` (at least one), the farthest from it and the next
/// (the same again when `k` is 1), through a max-heap of `k` keys.
fn farthest_two_of_nearest(k: usize, samples: Samples, end: End) -> [f32; 2] {
    let mut heap = std::collections::BinaryHeap::with_capacity(k);
    for block in samples.data.chunks(BLOCK * samples.channels.max(1)) {
        if heap.len() == k && heap.peek().is_some_and(|&top| end.passes_over(block, top)) {
            continue;
        }
        Samples { data: block, channels: samples.channels }.each(|x| {
            let kx = end.key(x);
            if heap.len() < k {
                heap.push(kx);
            } else if let Some(mut top) = heap.peek_mut() {
                if kx < *top {
                    *top = kx;
                }
            }
        });
    }
    let first = heap.pop().map_or(0.0, |k| end.value(k));
    let second = heap.pop().map_or(first, |k| end.value(k));
    [first, second]
}

/// `(x - P0.01) / (P99.9 - P0.01)` of each first-three-channel sample of `img` (module docs).
fn normaliser(img: &Pixels) -> (f64, f64) {
    let samples = Samples { data: img.data, channels: img.channels };
    let n = samples.count();
    let lo = percentile_of(n, 0.01, samples).unwrap_or(0.0);
    let hi = percentile_of(n, 99.9, samples).unwrap_or(0.0);
    (lo, if hi > lo { 1.0 / (hi - lo) } else { 0.0 })
}

/// The protocol's metrics of `pred` against `gt` (the same pixel count) over the pixels where
/// `mask` is true; `Err` when no pixel is left.
pub fn protocol_metrics(pred: &Pixels, gt: &Pixels, mask: &[bool]) -> Result<ProtocolMetrics, String> {
    if pred.len() != gt.len() || mask.len() != pred.len() {
        return Err(format!(
            "the prediction has {} pixels, the truth {} and the mask {}: they must agree",
            pred.len(),
            gt.len(),
            mask.len()
        ));
    }
    let (plo, pscale) = normaliser(pred);
    let (glo, gscale) = normaliser(gt);
    let (mut sq, mut pp, mut pg, mut gg, mut ang, mut norm_sq) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut n, mut nonfinite) = (0usize, 0usize);
    for i in (0..mask.len()).filter(|&i| mask[i]) {
        let (p, g) = (pred.rgb(i), gt.rgb(i));
        if !p.iter().chain(&g).all(|v| v.is_finite()) {
            nonfinite += 1;
            continue;
        }
        n += 1;
        let (mut dot, mut np2, mut ng2) = (0.0, 0.0, 0.0);
        for c in 0..3 {
            sq += (p[c] - g[c]).powi(2);
            dot += p[c] * g[c];
            np2 += p[c] * p[c];
            ng2 += g[c] * g[c];
            norm_sq += ((p[c] - plo) * pscale - (g[c] - glo) * gscale).powi(2);
        }
        pp += np2;
        pg += dot;
        gg += ng2;
        let denom = np2.sqrt() * ng2.sqrt();
        if denom > 0.0 {
            ang += (dot / denom).clamp(0.0, 1.0).acos();
        }
    }
    if n == 0 {
        return Err(match nonfinite {
            0 => "the mask selects no pixel".to_string(),
            k => format!("every one of the {k} masked pixels has a NaN or infinite value"),
        });
    }
    let nf = n as f64;
    let si = if pp > 0.0 { (gg - pg * pg / pp).max(0.0) } else { gg };
    Ok(ProtocolMetrics {
        rmse: (sq / nf).sqrt(),
        si_rmse: (si / nf).sqrt(),
        angular_error_deg: (ang / nf).to_degrees(),
        norm_rmse: (norm_sq / nf).sqrt(),
        pixels: n,
        nonfinite_pixels: nonfinite,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn px(data: &[f32]) -> Pixels<'_> {
        Pixels { data, channels: 3 }
    }

    #[test]
    fn identical_images_have_zero_error_and_a_scaled_one_zero_si_rmse() {
        let g: Vec<f32> = (0..30).map(|i| 0.1 + i as f32 * 0.37 % 2.0).collect();
        let mask = vec![true; 10];
        let m = protocol_metrics(&px(&g), &px(&g), &mask).unwrap();
        assert_eq!((m.rmse, m.si_rmse, m.norm_rmse), (0.0, 0.0, 0.0));
        assert!(m.angular_error_deg < 1e-5, "{}", m.angular_error_deg);
        let p: Vec<f32> = g.iter().map(|v| v * 4.0).collect();
        let m = protocol_metrics(&px(&p), &px(&g), &mask).unwrap();
        assert!(m.si_rmse < 1e-6 && m.rmse > 1.0, "{m:?}");
        // A scale changes neither the angle nor the percentile-normalised image.
        assert!(m.angular_error_deg < 1e-5 && m.norm_rmse < 1e-6, "{m:?}");
    }

    #[test]
    fn closed_forms_on_two_pixels() {
        // p = (1,0,0), (0,0,0); g = (0,1,0), (0,0,2); one masked pixel out of three.
        let p = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0, 5.0, 5.0];
        let g = [0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 9.0, 9.0, 9.0];
        let m = protocol_metrics(&px(&p), &px(&g), &[true, true, false]).unwrap();
        assert_eq!(m.pixels, 2);
        // sum (p - g)^2 = 2 + 4 over N = 2 pixels.
        assert!((m.rmse - 3f64.sqrt()).abs() < 1e-12);
        // p . g = 0: the best scale is 0 and the error is |g|^2 / N = 5 / 2.
        assert!((m.si_rmse - 2.5f64.sqrt()).abs() < 1e-12);
        // 90 degrees at the first pixel, 0 (black prediction) at the second: mean 45.
        assert!((m.angular_error_deg - 45.0).abs() < 1e-9);
    }

    #[test]
    fn an_all_zero_prediction_gets_the_limit_and_nan_is_counted_not_averaged() {
        let g = [1.0f32, 2.0, 2.0, 0.0, 0.0, 0.0];
        let m = protocol_metrics(&px(&[0.0; 6]), &px(&g), &[true, true]).unwrap();
        assert!((m.si_rmse - (9.0f64 / 2.0).sqrt()).abs() < 1e-12 && m.si_rmse == m.rmse, "{m:?}");
        let p = [f32::NAN, 1.0, 1.0, 1.0, 2.0, 2.0];
        let m = protocol_metrics(&px(&p), &px(&g), &[true, true]).unwrap();
        assert_eq!((m.pixels, m.nonfinite_pixels), (1, 1));
        assert!(m.rmse.is_finite() && m.norm_rmse.is_finite());
        let e = protocol_metrics(&px(&[f32::NAN; 3]), &px(&[1.0; 3]), &[true]).unwrap_err();
        assert!(e.contains("every one of the 1 masked pixels"), "{e}");
        assert!(protocol_metrics(&px(&g), &px(&g), &[false, false]).unwrap_err().contains("no pixel"));
        assert!(protocol_metrics(&px(&g), &px(&g[..3]), &[true]).is_err());
    }

    #[test]
    fn percentiles_interpolate_as_numpy() {
        // np.percentile([1, 2, 3, 4], [0, 25, 50, 99.9, 100]) = 1, 1.75, 2.5, 3.997, 4.
        for (q, want) in [(0.0, 1.0), (25.0, 1.75), (50.0, 2.5), (99.9, 3.997), (100.0, 4.0)] {
            let mut v = vec![4.0, 1.0, 3.0, 2.0];
            let got = numpy_percentile(&mut v, q).unwrap();
            assert!((got - want).abs() < 1e-12, "q {q}: {got}");
        }
        assert_eq!(numpy_percentile(&mut [], 50.0), None);
    }

    proptest::proptest! {
        /// The bounded heaps give numpy_percentile's value to the bit, ties, signs and zeros
        /// included, at ranks near either end and in the middle (the fallback).
        #[test]
        fn heap_percentiles_equal_the_selection(
            values in proptest::collection::vec(
                proptest::prop_oneof![-3.0f32..3.0, proptest::strategy::Just(0.0f32), proptest::strategy::Just(-0.0f32), 1e-30f32..1e30],
                1..3000,
            ),
            q in proptest::prop_oneof![0.0f64..1.0, 99.0f64..=100.0, 0.0f64..=100.0],
        ) {
            let got = percentile_of(values.len(), q, Samples { data: &values, channels: 1 }).unwrap();
            let mut v: Vec<f64> = values.iter().map(|&x| x as f64).collect();
            let want = numpy_percentile(&mut v, q).unwrap();
            proptest::prop_assert_eq!(got.to_bits(), want.to_bits(), "q {}", q);
        }

        /// The same on RGBA pixels that are mostly a zero background (whole blocks passed over),
        /// with negative zeros (below it in the order), NaN and infinite samples (left out) and an
        /// alpha that is not a sample.
        #[test]
        fn heap_percentiles_of_rgba_renders_equal_the_selection(
            pixels in proptest::collection::vec(
                proptest::prop_oneof![
                    8 => proptest::strategy::Just([0.0f32; 4]),
                    4 => proptest::strategy::Strategy::prop_map((0.0f32..5.0, 0.0f32..5.0, 0.0f32..5.0, 0.0f32..=1.0), |(r, g, b, a)| [r, g, b, a]),
                    1 => proptest::strategy::Just([f32::NAN, f32::INFINITY, 2.0, 1.0]),
                    1 => proptest::strategy::Just([-0.0, 7.0, f32::NEG_INFINITY, 0.5]),
                    1 => proptest::strategy::Just([-0.0, -0.0, -0.0, 1.0]),
                ],
                1..4000,
            ),
            q in proptest::prop_oneof![0.0f64..0.5, 99.5f64..=100.0],
        ) {
            let data: Vec<f32> = pixels.concat();
            let samples = Samples { data: &data, channels: 4 };
            let mut v: Vec<f64> = Vec::new();
            samples.each(|x| v.push(x as f64));
            proptest::prop_assume!(!v.is_empty());
            let got = percentile_of(samples.count(), q, samples).unwrap();
            let want = numpy_percentile(&mut v, q).unwrap();
            // Equal as numbers: the selection's next order statistic is a `min`, which (as numpy's
            // partition) does not order -0 and +0, so a zero's sign is not defined here.
            proptest::prop_assert!(got == want, "q {}: {} against {}", q, got, want);
        }
    }
}
