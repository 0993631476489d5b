//! `GuidedDistribution`: guide tables in front of a [`Distribution2D`]'s CDF searches, so that
//! drawing a texel costs O(1) expected memory reads instead of two binary searches.
//!
//! The method is Chen and Asau's guide table (1974; Devroye, *Non-Uniform Random Variate
//! Generation*, 1986, section III.2.4): for a CDF `c_0 = 0 <= .. <= c_n = 1` and G equal bins,
//! `guide[g]` is the interval containing `g / G`; a search for `u` starts at `guide[floor(u G)]`
//! and steps forward while `c_{i+1} <= u`. With G = n the expected number of steps is below 2.
//!
//! Why a guide table and not Walker's alias table (also O(1)): the guide table keeps the
//! inversion method, so [`GuidedDistribution::sample`] returns exactly the texel that
//! `Distribution2D::sample` returns for the same `(u1, u2)` (a test checks it), and a
//! stratified or low-discrepancy `(u1, u2)` stays stratified over the map (rows by `u1`, columns
//! by `u2`). The alias method scrambles that order, which would waste per-pixel Sobol points.

use rayon::prelude::*;

use crate::maths::prefetch;
use crate::values::distribution::clamp_unit;
use crate::values::Distribution2D;

/// Guide tables over a distribution's marginal CDF (H bins) and each row's conditional CDF (W
/// bins per row). 4 (W + 1) H bytes.
pub struct GuidedDistribution<'a> {
    dist: &'a Distribution2D,
    marginal_guide: Vec<u32>,
    /// Row y's W bins at `y * W ..`.
    conditional_guide: Vec<u32>,
}

/// The guide table of `cdf` (n + 1 entries) with `bins` bins: `guide[g] = find_interval(g / bins)`.
fn build_guide(cdf: &[f64], bins: usize, guide: &mut [u32]) {
    let n = cdf.len() - 1;
    let mut i = 0usize;
    for (g, slot) in guide.iter_mut().enumerate().take(bins) {
        let u = g as f64 / bins as f64;
        while i + 1 < n && cdf[i + 1] <= u {
            i += 1;
        }
        *slot = i as u32;
    }
}

/// The guide bin of `u` in a guide of `bins` bins.
#[inline(always)]
fn bin(u: f64, bins: usize) -> usize {
    ((u * bins as f64) as usize).min(bins - 1)
}

/// The index i with `cdf[i] <= u < cdf[i + 1]`, clamped to `[0, n - 1]` (as
/// `Distribution2D::sample`'s search), started from the guide. `u` in [0, 1).
#[inline]
fn guided_search(cdf: &[f64], guide: &[u32], u: f64) -> usize {
    search_from(cdf, guide[bin(u, guide.len())] as usize, u)
}

/// The search of [`guided_search`] from its guide's start `i`.
#[inline(always)]
fn search_from(cdf: &[f64], mut i: usize, u: f64) -> usize {
    let n = cdf.len() - 1;
    // `u * G` may round up to the next integer: step back if the guide overshot.
    while i > 0 && cdf[i] > u {
        i -= 1;
    }
    // Nearly every search ends within two steps: take those without branches (a step count
    // that varies from sample to sample is a branch the processor mispredicts), then loop.
    for _ in 0..2 {
        let step = ((i + 1 < n) & (cdf[(i + 1).min(n)] <= u)) as usize;
        i += step;
    }
    while i + 1 < n && cdf[i + 1] <= u {
        i += 1;
    }
    i
}

impl<'a> GuidedDistribution<'a> {
    /// Builds the tables (rows in parallel). Maps wider or taller than 2^32 texels are not
    /// representable as `u32` guides and are refused by the caller's size checks long before.
    pub fn new(dist: &'a Distribution2D) -> GuidedDistribution<'a> {
        let (w, h) = (dist.width(), dist.height());
        let mut marginal_guide = vec![0u32; h.max(1)];
        if h > 0 {
            build_guide(dist.marginal_cdf(), h, &mut marginal_guide);
        }
        let mut conditional_guide = vec![0u32; w * h];
        if w > 0 {
            conditional_guide
                .par_chunks_mut(w)
                .enumerate()
                .for_each(|(y, guide)| build_guide(dist.conditional_row(y), w, guide));
        }
        GuidedDistribution { dist, marginal_guide, conditional_guide }
    }

    /// The texel `Distribution2D::sample(u1, u2)` draws (without its pdf): the three stages
    /// below, one after the other.
    #[inline(always)]
    pub fn sample(&self, u1: f64, u2: f64) -> (usize, usize) {
        let mut draw = self.start(u1, u2);
        self.resume(&mut draw);
        self.finish(&draw)
    }

    /// [`Self::sample`] in three stages, so that a batch of samples can overlap its memory
    /// reads (the conditional guides and CDFs exceed the L2 cache on a 1024x512 map): stage 1
    /// finds the row (the small marginal tables) and prefetches the row's guide entry.
    #[inline(always)]
    pub fn start(&self, u1: f64, u2: f64) -> GuidedDraw {
        let (w, h) = (self.dist.width(), self.dist.height());
        let (u1, u2) = (clamp_unit(u1), clamp_unit(u2));
        let y = guided_search(self.dist.marginal_cdf(), &self.marginal_guide, u1).min(h - 1);
        let slot = y * w + bin(u2, w);
        prefetch(&self.conditional_guide[slot]);
        GuidedDraw { y, slot, u1, u2 }
    }

    /// Stage 2: reads the guide entry (its search start) and prefetches the CDF there.
    #[inline(always)]
    pub fn resume(&self, draw: &mut GuidedDraw) {
        let start = self.conditional_guide[draw.slot] as usize;
        let row = self.dist.conditional_row(draw.y);
        prefetch(&row[start]);
        // The search reads `cdf[start + 1]` next, on the following cache line one time in 8.
        prefetch(&row[(start + 1).min(row.len() - 1)]);
        draw.slot = start;
    }

    /// Stage 3: finishes the column search; the same texel as [`Self::sample`].
    #[inline(always)]
    pub fn finish(&self, draw: &GuidedDraw) -> (usize, usize) {
        let w = self.dist.width();
        (search_from(self.dist.conditional_row(draw.y), draw.slot, draw.u2).min(w - 1), draw.y)
    }

    /// [`Self::finish`] and where the uniforms fell inside the chosen intervals: `(x, y, rx,
    /// ry)` with `rx = (u2 - C_x) / (C_{x+1} - C_x)` in the row's conditional CDF and `ry` the
    /// same for `u1` in the marginal CDF. Under inversion, given the texel, `(rx, ry)` are
    /// independent and uniform on [0, 1) (Devroye 1986, section II.2), so they can place the
    /// point inside the texel: a continuous warp of `(u1, u2)`, as Mitsuba's and pbrt's
    /// piecewise-constant 2D distributions do, which keeps a low-discrepancy pair's
    /// stratification down to the point instead of spending a second pair on it. An interval of
    /// zero width (only reachable through the clamping at the ends) gives 0.5.
    #[inline(always)]
    pub fn finish_continuous(&self, draw: &GuidedDraw) -> (usize, usize, f64, f64) {
        let (x, y) = self.finish(draw);
        let remainder = |u: f64, lo: f64, hi: f64| {
            let width = hi - lo;
            if width > 0.0 {
                clamp_unit((u - lo) / width)
            } else {
                0.5
            }
        };
        let row = self.dist.conditional_row(y);
        let marginal = self.dist.marginal_cdf();
        (x, y, remainder(draw.u2, row[x], row[x + 1]), remainder(draw.u1, marginal[y], marginal[y + 1]))
    }
}

/// A texel draw between the stages of [`GuidedDistribution::start`]: the row, the guide slot
/// (after `resume`, the search start) and the clamped uniforms.
#[derive(Clone, Copy, Debug, Default)]
pub struct GuidedDraw {
    y: usize,
    slot: usize,
    u1: f64,
    u2: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::sampling::sequences::SplitMix64;
    use crate::values::Image;

    /// On maps with zero rows, zero columns, a single hot texel and random values, the guided
    /// search returns exactly `Distribution2D::sample`'s texel, also at u = 0, 1 and bin edges.
    #[test]
    fn same_texels_as_the_binary_search() {
        let mut rng = SplitMix64::new(11);
        let map = |w: usize, h: usize, f: &mut dyn FnMut(usize, usize) -> f32| {
            let data = (0..w * h).map(|i| f(i % w, i / w)).collect();
            Image::from_vec(w, h, 1, data)
        };
        let maps: Vec<Image> = vec![
            map(37, 19, &mut |x, y| if y % 3 == 0 || x % 5 == 1 { 0.0 } else { (x * y) as f32 }),
            map(64, 32, &mut |x, y| if (x, y) == (40, 10) { 1e6 } else { 1e-3 }),
            map(16, 8, &mut |x, _| if x < 15 { 0.0 } else { 1.0 }),
            map(128, 64, &mut |_, _| rng.next_f64() as f32 * 10.0),
            map(32, 16, &mut |_, _| 0.0),
        ];
        for map in &maps {
            let dist = Distribution2D::build(map, true, false).unwrap();
            let guided = GuidedDistribution::new(&dist);
            let mut us: Vec<f64> = vec![0.0, 1.0, 0.5, 1.0 - 1e-17, f64::NAN];
            for k in 0..=4 * map.width {
                us.push(k as f64 / (4 * map.width) as f64);
            }
            for _ in 0..20_000 {
                us.push(rng.next_f64());
            }
            for (i, &u1) in us.iter().enumerate() {
                let u2 = us[(i * 7 + 3) % us.len()];
                let (x, y, _) = dist.sample(u1, u2);
                assert_eq!(guided.sample(u1, u2), (x, y), "u = ({u1}, {u2})");
                let mut draw = guided.start(u1, u2);
                guided.resume(&mut draw);
                assert_eq!(guided.finish(&draw), (x, y), "staged, u = ({u1}, {u2})");
                let (cx, cy, rx, ry) = guided.finish_continuous(&draw);
                assert_eq!((cx, cy), (x, y));
                assert!((0.0..1.0).contains(&rx) && (0.0..1.0).contains(&ry), "remainders {rx} {ry}");
                // The remainders place (u1, u2) back inside the chosen intervals.
                let (m, row) = (dist.marginal_cdf(), dist.conditional_row(y));
                if m[y + 1] > m[y] && u1.is_finite() {
                    let back = m[y] + ry * (m[y + 1] - m[y]);
                    assert!((back - u1.clamp(0.0, 1.0)).abs() <= 1e-12 + 4.0 * f64::EPSILON, "{back} vs {u1}");
                }
                if row[x + 1] > row[x] && u2.is_finite() {
                    let back = row[x] + rx * (row[x + 1] - row[x]);
                    assert!((back - u2.clamp(0.0, 1.0)).abs() <= 1e-12 + 4.0 * f64::EPSILON, "{back} vs {u2}");
                }
            }
        }
    }
}
