//! Luminance statistics of an image: the weighted mean, weighted percentiles and counts of bad
//! texels (`Statistics`, and `Exposure(match_percentile)`).
//!
//! **Luminance.** A texel's luminance is `Y = 0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709,
//! [`crate::colour::REC709`], in f64)
//! of its first three channels, or its first channel itself in an image of fewer than three
//! channels (a scalar field, grey + alpha). Other channels (alpha) are ignored.
//!
//! **Bad texels.** A texel is counted in `nan` if one of those colour channels is NaN, else in
//! `inf` if one is infinite; such texels are left out of every other statistic (counted, never
//! propagated). A finite texel with a negative colour channel is counted in `negative` and kept.
//!
//! **Weights.** Lat-long maps (`latlong`): a texel in row `y` weighs its solid angle
//! [`latlong::texel_solid_angle`] (midpoint rule), so statistics are over the sphere, not the
//! pixel grid. Otherwise every texel weighs 1.
//!
//! **Weighted percentile.** With the kept texels' luminances `Y_i` (rounded to f32) and weights
//! `w_i`, `W(v) = sum_{Y_i <= v} w_i` and `W_total = W(+inf)`, the p-th percentile (p in
//! [0, 100]) is the **smallest texel value `v` with `W(v) >= p/100 W_total`**. So p = 0 is the
//! minimum, p = 100 the maximum, and with unit weights p = 50 of an even count is the lower
//! median. For p < 100 the comparison allows a relative slack of 1e-9 of `W_total`
//! (`W(v) >= p/100 W_total (1 - 1e-9)`), so that a cumulative weight equal to p% in exact
//! arithmetic counts as reaching it despite f64 rounding (a map 1 above the horizon and 0 below
//! has its median at the boundary: 0, the lower value). Sums are sequential f64 in increasing
//! `(Y, row)` order, so the result is deterministic. Memory: 8 bytes per texel (the sorted
//! `(f32, u32)` pairs).

use rayon::prelude::*;

use crate::geometry::latlong;
use crate::values::Image;

/// Relative slack in "the cumulative weight reaches p%" (see the module documentation).
pub const PERCENTILE_SLACK: f64 = 1e-9;

/// A texel's luminance (see the module documentation) and whether its colour channels are
/// NaN (`Some(false)`), infinite (`Some(true)`) or finite (`None`).
fn texel(px: &[f32]) -> (f64, Option<bool>) {
    let c = if px.len() >= 3 { &px[..3] } else { &px[..px.len().min(1)] };
    if c.iter().any(|v| v.is_nan()) {
        return (0.0, Some(false));
    }
    if c.iter().any(|v| v.is_infinite()) {
        return (0.0, Some(true));
    }
    let y = match c {
        [r, g, b] => crate::colour::rec709_luminance([*r, *g, *b]),
        [v] => *v as f64,
        _ => 0.0,
    };
    (y, None)
}

/// The luminances of an image's finite texels, sorted, with their weights and the counts of
/// the module documentation.
#[derive(Clone, Debug)]
pub struct LuminanceSamples {
    /// `(Y rounded to f32, row)` of every kept texel, increasing.
    sorted: Vec<(f32, u32)>,
    /// The weight of a texel in each row.
    row_weight: Vec<f64>,
    /// The weighted mean luminance of the kept texels (unrounded f64); 0 when none is kept.
    pub mean: f64,
    /// Texels with a NaN colour channel.
    pub nan: usize,
    /// Texels with an infinite (and no NaN) colour channel.
    pub inf: usize,
    /// Finite texels with a negative colour channel.
    pub negative: usize,
}

impl LuminanceSamples {
    /// The samples of `img`, weighted by solid angle when `latlong` (else 1 per texel).
    pub fn new(img: &Image, latlong: bool) -> Self {
        let (w, h, c) = (img.width, img.height, img.channels);
        let row_weight: Vec<f64> =
            (0..h).map(|y| if latlong { latlong::texel_solid_angle(y, w, h) } else { 1.0 }).collect();
        struct Row {
            samples: Vec<(f32, u32)>,
            sum: f64,
            weight: f64,
            nan: usize,
            inf: usize,
            negative: usize,
        }
        let rows: Vec<Row> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut r = Row { samples: Vec::with_capacity(w), sum: 0.0, weight: 0.0, nan: 0, inf: 0, negative: 0 };
                if c == 0 {
                    return r;
                }
                let mut sum = 0.0f64;
                for px in img.row(y).chunks_exact(c) {
                    match texel(px) {
                        (_, Some(false)) => r.nan += 1,
                        (_, Some(true)) => r.inf += 1,
                        (lum, None) => {
                            let colour = if c >= 3 { &px[..3] } else { &px[..1] };
                            if colour.iter().any(|&v| v < 0.0) {
                                r.negative += 1;
                            }
                            sum += lum;
                            r.samples.push((lum as f32, y as u32));
                        }
                    }
                }
                r.sum = sum * row_weight[y];
                r.weight = r.samples.len() as f64 * row_weight[y];
                r
            })
            .collect();
        let (mut sum, mut weight) = (0.0f64, 0.0f64);
        let (mut nan, mut inf, mut negative) = (0, 0, 0);
        let mut sorted = Vec::with_capacity(rows.iter().map(|r| r.samples.len()).sum());
        for r in rows {
            sum += r.sum;
            weight += r.weight;
            nan += r.nan;
            inf += r.inf;
            negative += r.negative;
            sorted.extend_from_slice(&r.samples);
        }
        sorted.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mean = if weight > 0.0 { sum / weight } else { 0.0 };
        LuminanceSamples { sorted, row_weight, mean: mean + 0.0, nan, inf, negative }
    }

    /// The number of kept (finite) texels.
    pub fn len(&self) -> usize {
        self.sorted.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sorted.is_empty()
    }

    /// The smallest and largest kept luminance (`None` when none is kept).
    pub fn min_max(&self) -> Option<(f64, f64)> {
        Some((self.sorted.first()?.0 as f64 + 0.0, self.sorted.last()?.0 as f64 + 0.0))
    }

    /// The weighted p-th percentiles for every `p` of `ps` (each in [0, 100]), in the order
    /// given; `None` when no texel is kept.
    pub fn percentiles(&self, ps: &[f64]) -> Vec<Option<f64>> {
        weighted_percentiles(&self.sorted, &self.row_weight, ps)
    }

    /// The same percentiles over the texels of positive luminance only.
    pub fn positive_percentiles(&self, ps: &[f64]) -> Vec<Option<f64>> {
        let first = self.sorted.partition_point(|&(v, _)| v <= 0.0);
        weighted_percentiles(&self.sorted[first..], &self.row_weight, ps)
    }

    /// `log2(P99.9 / P0.1)` over the texels of positive luminance (weighted the same way): the
    /// dynamic range in stops, robust to a few hot or dead texels; 0 when no texel is positive.
    pub fn dynamic_range_stops(&self) -> f64 {
        match self.positive_percentiles(&[0.1, 99.9])[..] {
            [Some(lo), Some(hi)] if lo > 0.0 => (hi / lo).log2(),
            _ => 0.0,
        }
    }
}

/// The weighted percentiles of the module documentation over `sorted` (increasing values, each
/// with its row; a row's texels weigh `row_weight[row]`). Rows out of `row_weight`'s range
/// weigh 0.
pub fn weighted_percentiles(sorted: &[(f32, u32)], row_weight: &[f64], ps: &[f64]) -> Vec<Option<f64>> {
    let mut out = vec![None; ps.len()];
    if sorted.is_empty() {
        return out;
    }
    let weight = |row: u32| row_weight.get(row as usize).copied().unwrap_or(0.0);
    let total: f64 = sorted.iter().map(|&(_, r)| weight(r)).sum();
    let mut order: Vec<usize> = (0..ps.len()).collect();
    order.sort_by(|&a, &b| ps[a].total_cmp(&ps[b]));
    // `next` texels consumed (whole groups of equal values), of cumulative weight `cum`.
    let (mut next, mut cum) = (0usize, 0.0f64);
    for k in order {
        let p = ps[k].clamp(0.0, 100.0);
        let target = if p >= 100.0 { total } else { p / 100.0 * total * (1.0 - PERCENTILE_SLACK) };
        while next < sorted.len() && (next == 0 || cum < target) {
            let v = sorted[next].0;
            while next < sorted.len() && sorted[next].0 == v {
                cum += weight(sorted[next].1);
                next += 1;
            }
        }
        out[k] = Some(sorted[next - 1].0 as f64 + 0.0);
    }
    out
}

/// The solid-angle-weighted p-th luminance percentile of a lat-long map (`None`: no finite
/// texel), as `Exposure(match_percentile)` uses it.
pub fn latlong_percentile(img: &Image, p: f64) -> Option<f64> {
    LuminanceSamples::new(img, true).percentiles(&[p]).first().copied().flatten()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::sampling::sequences::SplitMix64;

    /// The definition, literally: for each distinct value in increasing order, its cumulative
    /// weight; the first that reaches the target.
    fn naive(values: &[(f64, f64)], p: f64) -> f64 {
        let mut v: Vec<(f64, f64)> = values.to_vec();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: f64 = v.iter().map(|x| x.1).sum();
        let target = if p >= 100.0 { total } else { p / 100.0 * total * (1.0 - PERCENTILE_SLACK) };
        let mut distinct: Vec<f64> = v.iter().map(|x| x.0).collect();
        distinct.dedup();
        for d in distinct {
            let w: f64 = v.iter().filter(|x| x.0 <= d).map(|x| x.1).sum();
            if w >= target {
                return d;
            }
        }
        unreachable!("the largest value reaches every target")
    }

    #[test]
    fn matches_a_naive_sort_on_small_maps() {
        let mut rng = SplitMix64::new(11);
        for trial in 0..200 {
            let (w, h) = (1 + trial % 7, 1 + (trial / 7) % 5);
            // Few distinct values, so that ties and groups are common; weights are small
            // integers per row, so every cumulative weight is exact.
            let img =
                Image::from_vec(w, h, 1, (0..w * h).map(|_| (rng.next_f64() * 6.0).floor() as f32 - 1.0).collect());
            let row_weight: Vec<f64> = (0..h).map(|_| 1.0 + (rng.next_f64() * 4.0).floor()).collect();
            let mut s = LuminanceSamples::new(&img, false);
            s.row_weight = row_weight.clone();
            let values: Vec<(f64, f64)> = (0..w * h).map(|i| (img.data[i] as f64, row_weight[i / w])).collect();
            let ps = [0.0, 0.1, 1.0, 10.0, 25.0, 33.3, 50.0, 66.7, 75.0, 90.0, 99.0, 99.9, 100.0];
            let got = s.percentiles(&ps);
            for (p, g) in ps.iter().zip(&got) {
                assert_eq!(*g, Some(naive(&values, *p)), "trial {trial} ({w}x{h}), p {p}");
            }
            // The order of the requests does not matter.
            let rev: Vec<f64> = ps.iter().rev().copied().collect();
            let mut back = s.percentiles(&rev);
            back.reverse();
            assert_eq!(back, got);
        }
    }

    #[test]
    fn unit_weights_give_order_statistics() {
        let img = Image::from_vec(4, 1, 1, vec![3.0, 1.0, 4.0, 2.0]);
        let s = LuminanceSamples::new(&img, false);
        // p% of 4 texels: the smallest value with at least 4 p / 100 texels at or below it.
        let got = s.percentiles(&[0.0, 25.0, 26.0, 50.0, 51.0, 75.0, 100.0]);
        assert_eq!(got, [1.0, 1.0, 2.0, 2.0, 3.0, 3.0, 4.0].map(Some));
        assert_eq!(s.min_max(), Some((1.0, 4.0)));
        assert_eq!(s.mean, 2.5);
    }

    #[test]
    fn hemisphere_median_is_the_boundary_and_rows_follow_the_closed_form() {
        // 1 above the horizon, 0 below: each half carries exactly half the solid angle, so the
        // cumulative weight of 0 is exactly 50%: the median is 0, any p above 50 gives 1.
        for (w, h) in [(64, 32), (7, 10), (512, 256)] {
            let img = Image::from_fn_rgb(w, h, |_, y| if y < h / 2 { [1.0; 3] } else { [0.0; 3] });
            let s = LuminanceSamples::new(&img, true);
            let got = s.percentiles(&[49.0, 50.0, 50.001, 51.0]);
            assert_eq!(got, [0.0, 0.0, 1.0, 1.0].map(Some), "{w}x{h}");
            assert!((s.mean - 0.5).abs() < 1e-12, "{}", s.mean);
        }
        // Y = the row index: the weighted p-th percentile is the row whose band holds the
        // cumulative solid angle fraction p, (1 - cos theta) / 2 = p / 100 in the limit, so
        // row = floor(acos(1 - 2p/100) H / pi) within one row (the midpoint rule's weights).
        let (w, h) = (8, 200);
        let img = Image::from_vec(w, h, 1, (0..w * h).map(|i| (i / w) as f32).collect());
        let s = LuminanceSamples::new(&img, true);
        for p in [1.0, 10.0, 25.0, 50.0, 75.0, 90.0, 99.0] {
            let want = ((1.0 - 2.0 * p / 100.0f64).acos() * h as f64 / std::f64::consts::PI).floor();
            let got = s.percentiles(&[p])[0].unwrap();
            assert!((got - want).abs() <= 1.0, "p {p}: row {got}, closed form {want}");
        }
        // Unweighted, the same map's percentiles are uniform in the row.
        let plain = LuminanceSamples::new(&img, false);
        assert_eq!(plain.percentiles(&[50.0]), [Some(99.0)]);
    }

    #[test]
    fn bad_texels_are_counted_not_propagated() {
        let names = ["R", "G", "B", "A"].map(String::from).to_vec();
        let data = vec![
            1.0,
            1.0,
            1.0,
            f32::NAN, // alpha NaN: ignored
            f32::NAN,
            1.0,
            1.0,
            1.0,
            1.0,
            f32::INFINITY,
            1.0,
            1.0,
            f32::NAN,
            f32::NEG_INFINITY,
            1.0,
            1.0, // NaN wins
            -1.0,
            2.0,
            2.0,
            1.0,
            4.0,
            4.0,
            4.0,
            1.0,
        ];
        let img = Image::with_names(6, 1, names, data);
        let s = LuminanceSamples::new(&img, false);
        assert_eq!((s.nan, s.inf, s.negative, s.len()), (2, 1, 1, 3));
        let [wr, wg, wb] = crate::colour::REC709;
        let y_neg = -wr + wg * 2.0 + wb * 2.0;
        assert!((s.mean - (1.0 + y_neg + 4.0) / 3.0).abs() < 1e-12);
        assert!(s.percentiles(&[0.0, 50.0, 100.0]).iter().all(|v| v.is_some_and(f64::is_finite)));
        // Nothing kept: no percentile, a mean of 0.
        let all_nan = Image::from_vec(2, 1, 1, vec![f32::NAN, f32::NAN]);
        let s = LuminanceSamples::new(&all_nan, true);
        assert_eq!((s.nan, s.mean, s.percentiles(&[50.0])[0]), (2, 0.0, None));
        assert_eq!(s.dynamic_range_stops(), 0.0);
    }

    #[test]
    fn dynamic_range_uses_positive_texels_between_the_tails() {
        // 2000 texels, 1999 of them positive: one texel is 0.05% of them, below either tail.
        let mut data = vec![1.0f32; 2000];
        data[0] = 1e-6; // 0.05%: below P0.1
        data[1] = 0.0; // not positive: left out
        data[2] = 1e6; // 0.05%: above P99.9
        data[3] = 0.25;
        data[4] = 0.25;
        data[5] = 0.25; // 3 of 1999 positive texels: P0.1 = 0.25
        data[6] = 64.0;
        data[7] = 64.0;
        data[8] = 64.0;
        let img = Image::from_vec(2000, 1, 1, data);
        let s = LuminanceSamples::new(&img, false);
        assert_eq!(s.positive_percentiles(&[0.1, 99.9]), [Some(0.25), Some(64.0)]);
        assert_eq!(s.dynamic_range_stops(), 8.0);
        assert_eq!(s.min_max(), Some((0.0, 1e6)));
    }
}
