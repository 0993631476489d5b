//! `Distribution2D`: a 2D piecewise-constant distribution over a W x H lat-long map, for
//! importance sampling an environment map by luminance.
//!
//! The structure is pbrt-v4's `PiecewiseConstant2D` (src/pbrt/util/sampling.h; Pharr, Jakob,
//! Humphreys, *Physically Based Rendering* 4th ed., section A.5): one conditional CDF per row
//! (choosing a column) and a marginal CDF over rows (weighted by the row sums). Differences
//! from pbrt, all aimed at the failures listed in `../shared/NOTES.md`:
//! - every sum and CDF is f64 (pbrt: f32), so a 1e30 sun next to 1e-3 sky still normalises;
//! - the last entry of every CDF is exactly 1.0, and so is every entry after the last non-zero
//!   weight, so trailing zero rows/columns get an empty interval and are never chosen;
//! - intervals are found with `partition_point(|c| c <= u)`: an interval `[c_i, c_{i+1})` of
//!   zero width can never contain u, so zero-probability rows and columns are skipped, u = 0
//!   cannot give index -1 (YafaRay #92), and u is clamped to 1 - 2^-53 so u = 1 works;
//! - the pdf is the texel's probability divided by its solid angle, looked up at exactly the
//!   texel that was sampled (no half-texel offset: the map is piecewise constant over texels
//!   whose centres are `geometry::latlong`'s theta = pi (y + 1/2) / H, phi = 2 pi (x + 1/2) / W);
//!   the probability is read from the CDFs `sample` uses (below), so it is the probability with
//!   which `sample` returns the texel;
//! - an all-black map does not fail: it falls back to uniform sampling over solid angle.
//!
//! Texel weights: `w(x, y) = Y(x, y) sin(theta_y)` when `sin_theta` (the sampling density is then
//! proportional to luminance over solid angle; without the sine, poles are oversampled:
//! three-gpu-pathtracer #813), else `w = Y`. With `p(x, y) = w / sum(w)` and the midpoint texel
//! solid angle `dOmega_y = (2 pi / W)(pi / H) sin(theta_y)`, the density over solid angle is
//! `pdf = p / dOmega_y`, which for `sin_theta` is `Y W H / (2 pi^2 sum(w))` — pbrt-v3's
//! `mapPdf / (2 pi^2 sin(theta))` (InfiniteAreaLight::Pdf_Li) with
//! `mapPdf = Y W H / sum(w)` the density over the unit square.
//!
//! Memory (issue 14): the only buffer of the map's size is the conditional CDFs, `H (W + 1)` f64
//! (8 bytes a texel written for 4 read). pbrt also stores the weights `func` (another 8 bytes a
//! texel); here a texel's weight and probability are derived from its conditional CDF interval,
//! `w(x, y) = (C_y[x+1] - C_y[x]) row_sum_y` and `p(x, y) = w(x, y) / total` (`weight`,
//! `texel_probability`). That is exactly the probability with which `sample` picks the texel (the
//! length of the u2 interval that maps to it times the row's probability), and it equals
//! `Y sin(theta_y) / total` up to rounding: the interval's ends carry an absolute error of a few
//! 2^-53, so the relative error is about `2^-52 C_y[x+1] / (C_y[x+1] - C_y[x])`, i.e. 1e-16 for a
//! texel that holds a fair share of its row's weight and 1e-6 for one that holds 1e-10 of the
//! running sum before it. A texel whose weight is below about 2^-53 of the running sum of its row
//! up to it (a 1e-3 sky texel to the right of a 1e30 sun in the same row) disappears in the f64
//! running sum: its interval is empty and `sample` can never return it, so its probability and
//! pdf are 0 (when `func` was stored, the pdf of such a texel was positive although it could
//! never be sampled). Every texel with a non-empty interval in a row of positive sum has a
//! positive pdf, and every sampled texel has a positive weight. The row factor is
//! `row_sum_y / total`, not the marginal CDF's interval (which would lose the precision of a dim
//! row below bright ones), so a whole row whose sum vanishes in the marginal's running sum keeps
//! a tiny positive pdf although `sample` never picks it, as before.
//!
//! The rows' CDFs are written by the row kernels of `crate::values::distribution::row_kernels` (portable,
//! AVX2 and AVX-512, the same bits; at `crate::cpu::level`), each row straight into the
//! buffer's uninitialised capacity (a zeroed allocation is cleared by `calloc` when recycled: a
//! third of the build at 2048x1024). The buffer is asked to be backed by transparent huge pages
//! on Linux (`crate::memory::advise_huge_pages`): a fresh buffer of hundreds of MB is otherwise
//! faulted in and zeroed by the kernel 4 KiB at a time, which at 8192x4096 cost more than
//! everything else. Measured numbers are in docs/src/benchmarks/point-targets.md ("BuildCdf at scale").
//!
//! In graphs a `distribution`; saved as an image of its solid-angle pdf per texel. Cache payload:
//! width, height (u64), sin_theta, carries_light (u8), total, luminance_integral (f64), then the
//! f64 arrays conditional_cdf, row_sums, marginal_cdf. The weights (`func`) are not stored since
//! issue 14 (they are derived from the CDFs). An entry written with the older layout, which had
//! `func` before `conditional_cdf`, is never looked up (this file is part of the engine salt in
//! every cache key), and if one were decoded anyway its first array has `width * height`
//! entries, not `height * (width + 1)`, so the size check rejects it.

pub(crate) mod row_kernels;

use rayon::prelude::*;

use super::image::Image;
use crate::cpu::{self, Level};
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};
use crate::geometry::latlong::{texel_of_direction, texel_solid_angle, theta_of_row};
use crate::values::distribution::row_kernels::write_row;

/// The largest f64 below 1: 1 - 2^-53.
pub(crate) const ONE_MINUS_EPSILON: f64 = 1.0 - f64::EPSILON / 2.0;

#[derive(Debug, thiserror::Error)]
pub enum DistributionError {
    #[error("texel ({x}, {y}) is {value}: pass `sanitize: true` to treat NaN and negative texels as 0 and +Inf as the largest float")]
    BadTexel { x: usize, y: usize, value: f32 },
    #[error("{0}")]
    Invalid(String),
}

/// A piecewise-constant 2D distribution over a lat-long map (see the module documentation).
/// The fields are private: `build` establishes their invariants and the cache codec below checks
/// a decoded entry's sizes; other modules read them through the accessors.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    width: usize,
    height: usize,
    /// Whether the weights include sin(theta) (sampling proportional to luminance x solid angle).
    sin_theta: bool,
    /// `height` rows of `width + 1` entries: row y's CDF over columns, 0.0 .. exactly 1.0,
    /// non-decreasing; uniform `k / W` for a row of zero weight.
    conditional_cdf: Vec<f64>,
    /// Sum of each row's weights (`height` entries): `sin(theta_y)` (or 1) times the f64 sum of
    /// the row's luminance.
    row_sums: Vec<f64>,
    /// CDF over rows (`height + 1` entries, 0.0 .. exactly 1.0). Proportional to `row_sums`, or,
    /// when the map carries no light, to sin(theta_y) (uniform over solid angle).
    marginal_cdf: Vec<f64>,
    /// Sum of all weights (of `row_sums`).
    total: f64,
    /// `sum Y(x, y) dOmega_y`: the integral of the (sanitised) luminance over the sphere.
    luminance_integral: f64,
    /// `total` is finite and positive; false means the uniform solid-angle fallback is in use.
    carries_light: bool,
}

/// Normalises non-decreasing running sums `cdf[0] = 0, ..., cdf[n] = sum` into a CDF in place
/// and returns the sum `cdf[n]`. Entries equal to the sum (every entry after the last non-zero
/// weight) become exactly 1.0, the others `cdf[i] * (1 / sum)`: monotone (multiplication by a
/// positive constant is monotone under rounding) and at most 1 (for `cdf[i] < sum`,
/// `cdf[i] <= sum (1 - 2^-53)` and `fl(1 / sum) <= (1 + 2^-53) / sum`, so the exact product is
/// below 1), within 1.5 ulp of `cdf[i] / sum`; a multiply instead of a divide per entry, which
/// vectorises. A zero (or non-finite) sum gives the uniform CDF `k / n`. Either way `cdf[0] = 0`
/// and `cdf[n] = 1` exactly.
fn normalise_cdf(cdf: &mut [f64]) -> f64 {
    let n = cdf.len() - 1;
    let sum = cdf[n];
    if sum > 0.0 && sum.is_finite() {
        let inv = 1.0 / sum;
        for c in cdf.iter_mut() {
            *c = if *c == sum { 1.0 } else { *c * inv };
        }
    } else {
        for (k, c) in cdf.iter_mut().enumerate() {
            *c = k as f64 / n as f64;
        }
    }
    cdf[0] = 0.0;
    cdf[n] = 1.0;
    sum
}

/// The index i with `cdf[i] <= u < cdf[i+1]` (cdf non-decreasing from 0 to 1, `u` in [0, 1)):
/// `partition_point(|c| c <= u) - 1`, clamped to `[0, n - 1]`. Zero-width intervals never match.
#[inline]
fn find_interval(cdf: &[f64], u: f64) -> usize {
    let n = cdf.len() - 1;
    cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n.saturating_sub(1))
}

/// u clamped into [0, 1 - 2^-53]; NaN becomes 0.
#[inline]
pub(crate) fn clamp_unit(u: f64) -> f64 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, ONE_MINUS_EPSILON)
    }
}

/// The texel value `build` uses: NaN and negatives (including -Inf) are 0 and +Inf is
/// `f32::MAX` when sanitising; `None` for a bad texel otherwise.
fn sanitised(v: f32, sanitize: bool) -> Option<f32> {
    if v.is_nan() || v < 0.0 || v == f32::INFINITY {
        if !sanitize {
            return None;
        }
        Some(if v == f32::INFINITY { f32::MAX } else { 0.0 })
    } else {
        Some(v)
    }
}

impl Distribution2D {
    /// Builds the distribution of a one-channel luminance map (rows in parallel).
    ///
    /// Texels that are NaN, +-Inf or negative are an error (`BadTexel`, the first in row-major
    /// order) unless `sanitize`, which maps NaN and negatives (including -Inf) to 0 and +Inf to
    /// `f32::MAX`. See the module documentation for the weights and the all-black fallback.
    pub fn build(luminance: &Image, sin_theta: bool, sanitize: bool) -> Result<Distribution2D, DistributionError> {
        Self::build_with(luminance, sin_theta, sanitize, cpu::level())
    }

    fn build_with(
        luminance: &Image,
        sin_theta: bool,
        sanitize: bool,
        level: Level,
    ) -> Result<Distribution2D, DistributionError> {
        if luminance.channels != 1 {
            return Err(DistributionError::Invalid(format!(
                "a distribution is built from a one-channel luminance map, got {} channels",
                luminance.channels
            )));
        }
        let (w, h) = (luminance.width, luminance.height);
        if w == 0 || h == 0 {
            return Err(DistributionError::Invalid(format!("cannot build a distribution over an empty {w}x{h} map")));
        }
        if luminance.data.len() != w * h {
            return Err(DistributionError::Invalid(format!(
                "luminance buffer holds {} values, expected {w}x{h} = {}",
                luminance.data.len(),
                w * h
            )));
        }

        // The only buffer of the map's size: written once, row by row (see the module docs),
        // into its uninitialised capacity; its length covers the rows once all are written.
        let entries = h * (w + 1);
        let mut conditional_cdf: Vec<f64> = Vec::with_capacity(entries);
        let spare = &mut conditional_cdf.spare_capacity_mut()[..entries];
        crate::memory::advise_huge_pages(spare);

        // Per row: its weight (`Y sin(theta_y)` or `Y` summed: the sine is constant along a row,
        // so it scales the row's sum and cancels out of its conditional CDF) and its share of the
        // luminance integral, both found here so that their trigonometry runs in parallel; or the
        // row's first bad texel (x, value).
        let rows: Vec<Result<(f64, f64), (usize, f32)>> = spare
            .par_chunks_mut(w + 1)
            .enumerate()
            .map(|(y, crow)| {
                let src = luminance.row(y);
                let (mut sum, min) = write_row(level, src, crow);
                if !(sum.is_finite() && min >= 0.0) {
                    // A bad texel: name the first, or redo the row from its sanitised copy
                    // (which has none, so the kernel writes it all).
                    let mut clean = Vec::with_capacity(w);
                    for (x, &v) in src.iter().enumerate() {
                        clean.push(sanitised(v, sanitize).ok_or((x, v))?);
                    }
                    sum = write_row(level, &clean, crow).0;
                }
                let weight = if sin_theta { sum * theta_of_row(y, h).sin() } else { sum };
                Ok((weight, sum * texel_solid_angle(y, w, h)))
            })
            .collect();
        if rows.iter().all(Result::is_ok) {
            // SAFETY: every row returned Ok after its kernel wrote all its w + 1 entries (from
            // the row or its sanitised copy), and the rows tile the first `entries` slots of the
            // capacity.
            unsafe { conditional_cdf.set_len(entries) };
        }

        let mut row_sums = Vec::with_capacity(h);
        let mut luminance_integral = 0.0f64;
        for (y, r) in rows.into_iter().enumerate() {
            match r {
                Ok((weight, integral)) => {
                    row_sums.push(weight);
                    luminance_integral += integral;
                }
                Err((x, value)) => return Err(DistributionError::BadTexel { x, y, value }),
            }
        }

        let mut marginal_cdf = vec![0.0f64; h + 1];
        for y in 0..h {
            marginal_cdf[y + 1] = marginal_cdf[y] + row_sums[y];
        }
        let total = marginal_cdf[h];
        let carries_light = total > 0.0 && total.is_finite();
        if !carries_light {
            // Uniform over solid angle: rows in proportion to sin(theta_y) (all conditionals are
            // already uniform, every row being zero).
            for y in 0..h {
                marginal_cdf[y + 1] = marginal_cdf[y] + theta_of_row(y, h).sin();
            }
        }
        normalise_cdf(&mut marginal_cdf);

        Ok(Distribution2D {
            width: w,
            height: h,
            sin_theta,
            conditional_cdf,
            row_sums,
            marginal_cdf,
            total,
            luminance_integral,
            carries_light,
        })
    }

    /// Texels per row of the map the distribution was built from.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows of the map.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether the weights include sin(theta) (sampling proportional to luminance x solid angle).
    pub fn sin_theta(&self) -> bool {
        self.sin_theta
    }

    /// The CDF over rows (`height + 1` entries, 0.0 .. exactly 1.0), proportional to the row
    /// sums, or to sin(theta_y) when the map carries no light.
    #[inline]
    pub fn marginal_cdf(&self) -> &[f64] {
        &self.marginal_cdf
    }

    /// Every row's conditional CDF, row after row (`height` rows of `width + 1` entries; one row
    /// is [`Distribution2D::conditional_row`]).
    pub fn conditional_cdf(&self) -> &[f64] {
        &self.conditional_cdf
    }

    /// The sum of each row's weights (`height` entries).
    pub fn row_sums(&self) -> &[f64] {
        &self.row_sums
    }

    /// The sum of all weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// `sum Y(x, y) dOmega_y`: the integral of the (sanitised) luminance over the sphere.
    pub fn luminance_integral(&self) -> f64 {
        self.luminance_integral
    }

    /// Whether the total weight is finite and positive; false means the uniform solid-angle
    /// fallback is in use.
    pub fn carries_light(&self) -> bool {
        self.carries_light
    }

    /// Row y's conditional CDF (`width + 1` entries).
    #[inline]
    pub fn conditional_row(&self, y: usize) -> &[f64] {
        let n = self.width + 1;
        &self.conditional_cdf[y * n..(y + 1) * n]
    }

    /// Draws a texel: the row from the marginal CDF with `u1`, the column from that row's
    /// conditional CDF with `u2` (both clamped to [0, 1 - 2^-53]; 0 and 1 are valid).
    /// Returns `(x, y, pdf)` with `pdf = self.pdf(x, y)` (per steradian). When the map carries
    /// light the texel always has a positive weight, so the pdf is positive and finite.
    pub fn sample(&self, u1: f64, u2: f64) -> (usize, usize, f64) {
        let y = find_interval(&self.marginal_cdf, clamp_unit(u1)).min(self.height.saturating_sub(1));
        let x = find_interval(self.conditional_row(y), clamp_unit(u2)).min(self.width.saturating_sub(1));
        (x, y, self.pdf(x, y))
    }

    /// The discrete probability of texel (x, y), read from the CDFs that `sample` uses: when the
    /// map carries light, the width of its interval in row y's conditional CDF times the row's
    /// probability, `(C_{x+1} - C_x) row_sums[y] / total` (= `w(x, y) / total` up to rounding:
    /// see the module documentation); otherwise the fallback's `P(row y) / W`, `(M_{y+1} -
    /// M_y)(C_{x+1} - C_x)` with uniform conditionals. 0 outside the map.
    pub fn texel_probability(&self, x: usize, y: usize) -> f64 {
        if x >= self.width || y >= self.height {
            return 0.0;
        }
        if self.carries_light {
            let row = self.conditional_row(y);
            (row[x + 1] - row[x]) * (self.row_sums[y] / self.total)
        } else {
            let row = self.conditional_row(y);
            (self.marginal_cdf[y + 1] - self.marginal_cdf[y]) * (row[x + 1] - row[x])
        }
    }

    /// Density over solid angle of `sample` at texel (x, y): `texel_probability / dOmega_y`,
    /// `dOmega_y = (2 pi / W)(pi / H) sin(theta_y)` (always > 0 at row centres). For `sin_theta`
    /// this is `Y W H / (2 pi^2 total)` (pbrt-v3's `mapPdf / (2 pi^2 sin theta)`). Finite, >= 0;
    /// 0 outside the map.
    pub fn pdf(&self, x: usize, y: usize) -> f64 {
        if x >= self.width || y >= self.height {
            return 0.0;
        }
        let p = self.texel_probability(x, y) / texel_solid_angle(y, self.width, self.height);
        if p.is_finite() && p > 0.0 {
            p
        } else {
            0.0
        }
    }

    /// Density over solid angle of direction `d` (the texel containing it; for MIS).
    pub fn pdf_direction(&self, d: [f64; 3]) -> f64 {
        let (x, y) = texel_of_direction(d, self.width, self.height);
        self.pdf(x, y)
    }

    /// The weight `w(x, y)` of texel (x, y) as the distribution sees it: row y's sum times the
    /// width of the texel's conditional CDF interval (`Y sin(theta_y)`, or `Y`, up to rounding; 0
    /// for a texel whose interval is empty). 0 outside the map.
    pub fn weight(&self, x: usize, y: usize) -> f64 {
        if x >= self.width || y >= self.height {
            return 0.0;
        }
        let row = self.conditional_row(y);
        (row[x + 1] - row[x]) * self.row_sums[y]
    }

    /// All texel weights, row-major (`width * height`), computed on demand by `weight` (the
    /// distribution does not store them).
    pub fn weights(&self) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            let row = self.conditional_row(y);
            out.extend(row.windows(2).map(|c| (c[1] - c[0]) * self.row_sums[y]));
        }
        out
    }

    /// Approximate heap plus inline size in bytes.
    pub fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + 8 * (self.conditional_cdf.len() + self.row_sums.len() + self.marginal_cdf.len())
    }
}

pub static DISTRIBUTION: TypeSpec = TypeSpec {
    name: "distribution",
    doc: "a piecewise-constant 2D sampling distribution over a lat-long map (f64)",
    decode,
};

impl ValueData for Distribution2D {
    fn value_type(&self) -> ValueType {
        ValueType(&DISTRIBUTION)
    }
    fn approx_bytes(&self) -> usize {
        Distribution2D::approx_bytes(self)
    }
    /// What `--print cdf` shows: the size, the light it carries, and its brightest texel (where
    /// it is and what share of the samples it draws: `P(x, y) = P(row y) P(x | y)`).
    fn summary(&self) -> String {
        let (w, h) = (self.width, self.height);
        let weighting = if self.sin_theta { "luminance x sin(theta)" } else { "luminance" };
        if !self.carries_light {
            return format!("a {w} x {h} distribution carrying no light: uniform over solid angle");
        }
        let (mut best, mut at) = (0.0f64, (0, 0));
        for y in 0..h {
            let row = self.marginal_cdf[y + 1] - self.marginal_cdf[y];
            let cdf = &self.conditional_cdf[y * (w + 1)..(y + 1) * (w + 1)];
            for x in 0..w {
                let p = row * (cdf[x + 1] - cdf[x]);
                if p > best {
                    (best, at) = (p, (x, y));
                }
            }
        }
        let (x, y) = at;
        let d = crate::geometry::latlong::texel_direction(x, y, w, h);
        format!(
            "a {w} x {h} distribution over {weighting}; luminance integral {:.6e} (over the sphere, in sr); \
             brightest texel ({x}, {y}), direction ({:.4}, {:.4}, {:.4}) (theta {:.2} deg, phi {:.2} deg), \
             draws {:.3}% of the samples ({:.1}x a uniform texel's)",
            self.luminance_integral,
            d[0],
            d[1],
            d[2],
            crate::geometry::latlong::theta_of_row(y, h).to_degrees(),
            crate::geometry::latlong::phi_of_column(x, w).to_degrees(),
            100.0 * best,
            best * (w * h) as f64,
        )
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.width as u64);
        w.u64(self.height as u64);
        w.u8(u8::from(self.sin_theta));
        w.u8(u8::from(self.carries_light));
        w.f64(self.total);
        w.f64(self.luminance_integral);
        w.f64s(&self.conditional_cdf);
        w.f64s(&self.row_sums);
        w.f64s(&self.marginal_cdf);
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = r.usize()?;
    let height = r.usize()?;
    let sin_theta = r.u8()? != 0;
    let carries_light = r.u8()? != 0;
    let total = r.f64()?;
    let luminance_integral = r.f64()?;
    let conditional_cdf = r.f64s()?;
    let row_sums = r.f64s()?;
    let marginal_cdf = r.f64s()?;
    r.finish()?;
    let n = width.checked_mul(height).ok_or("distribution size overflows")?;
    if n == 0
        || Some(conditional_cdf.len()) != height.checked_mul(width + 1)
        || row_sums.len() != height
        || marginal_cdf.len() != height + 1
    {
        return Err("distribution arrays do not match its size".into());
    }
    Ok(Value::new(Distribution2D {
        width,
        height,
        sin_theta,
        conditional_cdf,
        row_sums,
        marginal_cdf,
        total,
        luminance_integral,
        carries_light,
    }))
}

/// The distribution's solid-angle pdf per texel, as a scalar field.
pub fn pdf_image(d: &Distribution2D) -> Image {
    let mut img = Image::new(d.width, d.height, 1);
    for y in 0..d.height {
        for x in 0..d.width {
            img.data[y * d.width + x] = d.pdf(x, y) as f32;
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    // Test-only: the generator and the chi-square test are maths'; `data` itself depends on
    // `maths` only for the row kernels, a leaf (the lat-long geometry it needs is
    // `geometry::latlong`).
    use crate::maths::sampling::chi_square::chi_square_test;
    use crate::maths::sampling::sequences::SplitMix64;
    use std::f64::consts::PI;
    use std::mem::MaybeUninit;

    /// A random map: values in [0, 10) with about a fifth of the texels zero, and row
    /// `zero_row` (if any) all zero.
    fn random_map(w: usize, h: usize, seed: u64, zero_row: Option<usize>) -> Image {
        let mut rng = SplitMix64::new(seed);
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            for _ in 0..w {
                let v = if rng.next_f64() < 0.2 || Some(y) == zero_row { 0.0 } else { 10.0 * rng.next_f64() };
                data.push(v as f32);
            }
        }
        Image::from_vec(w, h, 1, data)
    }

    /// `sum_{x,y} pdf(x, y) dOmega_y`, which must be 1.
    fn pdf_integral(d: &Distribution2D) -> f64 {
        let mut s = 0.0;
        for y in 0..d.height {
            let sa = texel_solid_angle(y, d.width, d.height);
            for x in 0..d.width {
                s += d.pdf(x, y) * sa;
            }
        }
        s
    }

    fn check_invariants(d: &Distribution2D) {
        assert_eq!(d.weights().len(), d.width * d.height);
        assert_eq!(d.conditional_cdf.len(), d.height * (d.width + 1));
        assert_eq!(d.row_sums.len(), d.height);
        assert_eq!(d.marginal_cdf.len(), d.height + 1);
        assert_eq!(d.marginal_cdf[0], 0.0);
        assert_eq!(d.marginal_cdf[d.height], 1.0);
        assert!(d.marginal_cdf.windows(2).all(|p| p[0] <= p[1]));
        for y in 0..d.height {
            let row = d.conditional_row(y);
            assert_eq!(row[0], 0.0);
            assert_eq!(row[d.width], 1.0);
            assert!(row.windows(2).all(|p| p[0] <= p[1]));
        }
        for y in 0..d.height {
            for x in 0..d.width {
                let p = d.pdf(x, y);
                assert!(p.is_finite() && p >= 0.0);
            }
        }
    }

    fn build(img: &Image, sin_theta: bool) -> Distribution2D {
        let d = Distribution2D::build(img, sin_theta, false).unwrap();
        check_invariants(&d);
        d
    }

    #[test]
    fn pdf_integrates_to_one() {
        let mut maps = vec![
            random_map(16, 8, 1, None),
            random_map(33, 17, 2, Some(5)),
            random_map(64, 32, 3, Some(0)),
            Image::from_vec(8, 4, 1, vec![2.5; 32]),
            Image::new(12, 6, 1),
            Image::from_vec(1, 1, 1, vec![3.0]),
            Image::from_vec(1, 1, 1, vec![0.0]),
            random_map(1, 7, 4, None),
            random_map(7, 1, 5, None),
            Image::new(1, 7, 1),
            Image::new(7, 1, 1),
        ];
        let mut hot = Image::new(16, 8, 1);
        hot.data[5 * 16 + 3] = 1000.0;
        maps.push(hot);
        for img in &maps {
            for sin_theta in [true, false] {
                let d = build(img, sin_theta);
                let s = pdf_integral(&d);
                assert!((s - 1.0).abs() < 1e-12, "{}x{} sin {sin_theta}: {s}", img.width, img.height);
                let p: f64 = (0..d.height)
                    .flat_map(|y| (0..d.width).map(move |x| (x, y)))
                    .map(|(x, y)| d.texel_probability(x, y))
                    .sum();
                assert!((p - 1.0).abs() < 1e-12);
            }
        }
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

    #[test]
    fn all_black_map_falls_back_to_uniform_solid_angle() {
        let d = build(&Image::new(16, 8, 1), true);
        assert!(!d.carries_light);
        assert_eq!(d.total, 0.0);
        assert_eq!(d.luminance_integral, 0.0);
        let p0 = d.pdf(0, 0);
        for y in 0..8 {
            for x in 0..16 {
                assert!((d.pdf(x, y) - p0).abs() < 1e-12 * p0);
            }
        }
        assert!((p0 - 1.0 / (4.0 * PI)).abs() < 1e-2 / (4.0 * PI));
        let (x, y, pdf) = d.sample(0.3, 0.9);
        assert!(x < 16 && y < 8 && pdf > 0.0);
    }

    #[test]
    fn hot_texel_is_always_sampled() {
        let mut img = Image::new(16, 8, 1);
        img.data[5 * 16 + 3] = 1e6;
        let d = build(&img, true);
        let mut rng = SplitMix64::new(3);
        let mut us = vec![(0.0, 0.0), (1.0, 1.0), (ONE_MINUS_EPSILON, ONE_MINUS_EPSILON), (0.0, 1.0), (1.0, 0.0)];
        for _ in 0..1000 {
            us.push((rng.next_f64(), rng.next_f64()));
        }
        let expect = d.pdf(3, 5);
        assert!(expect > 0.0);
        for (u1, u2) in us {
            assert_eq!(d.sample(u1, u2), (3, 5, expect), "u = ({u1}, {u2})");
        }
        // pdf * solid angle = 1 for the single texel.
        assert!((expect * texel_solid_angle(5, 16, 8) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn edge_u_values_skip_zero_rows_and_columns() {
        // Zero first and last rows, zero first and last columns.
        let (w, h) = (6usize, 5usize);
        let mut img = Image::new(w, h, 1);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                img.data[y * w + x] = 1.0 + (x * y) as f32;
            }
        }
        for sin_theta in [true, false] {
            let d = build(&img, sin_theta);
            for &u1 in &[0.0, f64::MIN_POSITIVE, ONE_MINUS_EPSILON, 1.0, 1.5, -0.5, f64::NAN] {
                for &u2 in &[0.0, ONE_MINUS_EPSILON, 1.0] {
                    let (x, y, pdf) = d.sample(u1, u2);
                    assert!((1..w - 1).contains(&x) && (1..h - 1).contains(&y), "u ({u1}, {u2}) -> ({x}, {y})");
                    assert!(pdf.is_finite() && pdf > 0.0);
                    assert_eq!(pdf, d.pdf(x, y));
                }
            }
            assert_eq!(d.sample(0.0, 0.0).0, 1);
            assert_eq!(d.sample(0.0, 0.0).1, 1);
            assert_eq!(d.sample(1.0, 1.0).0, w - 2);
            assert_eq!(d.sample(1.0, 1.0).1, h - 2);
        }
    }

    #[test]
    fn samples_never_land_on_zero_texels() {
        let img = random_map(32, 16, 9, Some(7));
        let d = build(&img, true);
        let mut rng = SplitMix64::new(10);
        for _ in 0..20_000 {
            let (x, y, pdf) = d.sample(rng.next_f64(), rng.next_f64());
            assert!(img.data[y * 32 + x] > 0.0 && d.weight(x, y) > 0.0 && pdf > 0.0);
            assert_ne!(y, 7);
        }
    }

    #[test]
    fn chi_square_against_texel_probability() {
        let (w, h) = (8usize, 6usize);
        let img = random_map(w, h, 21, Some(2));
        for sin_theta in [true, false] {
            let d = build(&img, sin_theta);
            let n = 100_000usize;
            let mut obs = vec![0.0; w * h];
            let mut rng = SplitMix64::new(77);
            for _ in 0..n {
                let (x, y, _) = d.sample(rng.next_f64(), rng.next_f64());
                obs[y * w + x] += 1.0;
            }
            let exp: Vec<f64> = (0..w * h).map(|i| n as f64 * d.texel_probability(i % w, i / w)).collect();
            let r = chi_square_test(&obs, &exp, 5.0);
            assert_eq!(r.impossible_cells, 0);
            assert!(r.p_value > 1e-4, "sin {sin_theta}: {r:?}");
        }
    }

    #[test]
    fn pdf_matches_pbrt_v3_formula() {
        let (w, h) = (20usize, 10usize);
        let img = random_map(w, h, 31, None);
        let d = build(&img, true);
        for y in 0..h {
            for x in 0..w {
                let lum = img.data[y * w + x] as f64;
                let expect = lum * (w * h) as f64 / (2.0 * PI * PI * d.total);
                let got = d.pdf(x, y);
                assert!((got - expect).abs() <= 1e-12 * expect.max(1e-300), "({x}, {y}): {got} vs {expect}");
            }
        }
    }

    #[test]
    fn constant_map_is_uniform_over_the_sphere() {
        let (w, h) = (64usize, 32usize);
        let d = build(&Image::from_vec(w, h, 1, vec![1.0; w * h]), true);
        let target = 1.0 / (4.0 * PI);
        for y in 0..h {
            for x in [0, w / 2, w - 1] {
                let p = d.pdf(x, y);
                // Midpoint rule: sum_y sin(theta_y) (pi / H) = 2 (1 + O(1/H^2)).
                assert!((p - target).abs() < 1e-3 * target, "row {y}: {p}");
            }
        }
        // The luminance integral of a constant 1 is the sphere's area, 4 pi (midpoint rule).
        assert!((d.luminance_integral - 4.0 * PI).abs() < 1e-3 * 4.0 * PI);
    }

    #[test]
    fn bad_texels_error_or_are_sanitised() {
        let (w, h) = (4usize, 5usize);
        let mut img = Image::from_vec(w, h, 1, vec![1.0; w * h]);
        img.data[3 * w] = -1.0; // (0, 3)
        img.data[w + 2] = f32::NAN; // (2, 1): first in row-major order
        img.data[4 * w + 1] = f32::INFINITY; // (1, 4)
        img.data[2 * w + 3] = f32::NEG_INFINITY; // (3, 2)
        match Distribution2D::build(&img, true, false) {
            Err(DistributionError::BadTexel { x, y, value }) => {
                assert_eq!((x, y), (2, 1));
                assert!(value.is_nan());
            }
            other => panic!("expected BadTexel, got {other:?}"),
        }
        let msg = Distribution2D::build(&img, true, false).unwrap_err().to_string();
        assert!(msg.contains("sanitize: true"), "{msg}");

        let d = Distribution2D::build(&img, true, true).unwrap();
        check_invariants(&d);
        assert!(d.carries_light);
        assert_eq!(d.texel_probability(2, 1), 0.0);
        assert_eq!(d.texel_probability(0, 3), 0.0);
        assert_eq!(d.texel_probability(3, 2), 0.0);
        let expect = f32::MAX as f64 * theta_of_row(4, h).sin();
        assert!((d.weight(1, 4) - expect).abs() <= 1e-15 * expect);
        assert!(d.texel_probability(1, 4) > 0.999_999);
        assert!((pdf_integral(&d) - 1.0).abs() < 1e-12);
        assert!(d.luminance_integral.is_finite());

        // Only an infinite texel: still an error without sanitising.
        let mut img = Image::from_vec(2, 2, 1, vec![1.0; 4]);
        img.data[3] = f32::INFINITY;
        assert!(matches!(
            Distribution2D::build(&img, false, false),
            Err(DistributionError::BadTexel { x: 1, y: 1, .. })
        ));
        // -0.0 is fine and weighs nothing.
        let img = Image::from_vec(2, 1, 1, vec![-0.0, 1.0]);
        let d = build(&img, true);
        assert_eq!(d.texel_probability(0, 0), 0.0);
        assert_eq!(d.sample(0.0, 0.0).0, 1);
    }

    #[test]
    fn huge_dynamic_range() {
        let (w, h) = (16usize, 8usize);
        let mut img = random_map(w, h, 41, None);
        img.data[3 * w + 5] = 1e30;
        img.data[6 * w + 1] = f32::MAX;
        img.data[0] = 1e-30;
        for sin_theta in [true, false] {
            let d = build(&img, sin_theta);
            assert!(d.total.is_finite() && d.carries_light);
            assert!((pdf_integral(&d) - 1.0).abs() < 1e-12);
            let (x, y, pdf) = d.sample(0.5, 0.5);
            assert!(pdf.is_finite() && pdf > 0.0 && img.data[y * w + x] > 0.0);
            // A tiny texel keeps a tiny but positive, finite pdf.
            assert!(d.pdf(0, 0) > 0.0);
        }
    }

    #[test]
    fn rejects_wrong_shapes() {
        assert!(matches!(Distribution2D::build(&Image::new(4, 2, 3), true, false), Err(DistributionError::Invalid(_))));
        assert!(matches!(Distribution2D::build(&Image::new(0, 2, 1), true, false), Err(DistributionError::Invalid(_))));
        assert!(matches!(Distribution2D::build(&Image::new(4, 0, 1), true, false), Err(DistributionError::Invalid(_))));
    }

    #[test]
    fn thin_maps_sample_correctly() {
        for (w, h) in [(1usize, 7usize), (7, 1), (1, 1)] {
            let img = random_map(w, h, 51, None);
            let d = build(&img, true);
            for &(u1, u2) in &[(0.0, 0.0), (1.0, 1.0), (0.5, 0.5), (ONE_MINUS_EPSILON, 0.0)] {
                let (x, y, pdf) = d.sample(u1, u2);
                assert!(x < w && y < h && pdf.is_finite());
                if d.carries_light {
                    assert!(pdf > 0.0);
                }
            }
        }
    }

    #[test]
    fn parallel_build_is_deterministic() {
        let img = random_map(50, 25, 61, Some(3));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let one = pool.install(|| Distribution2D::build(&img, true, false).unwrap());
        let many = Distribution2D::build(&img, true, false).unwrap();
        assert_eq!(one, many);
        assert!(many.approx_bytes() >= 8 * (25 * 51 + 25 + 26));
        // pdf_direction agrees with the texel lookup at texel centres.
        for (x, y) in [(0usize, 0usize), (10, 7), (49, 24)] {
            let dir = crate::geometry::latlong::texel_direction(x, y, 50, 25);
            assert_eq!(many.pdf_direction(dir), many.pdf(x, y));
        }
    }

    #[test]
    fn weights_match_the_luminance_to_rounding() {
        // Large enough (4.8 MiB of CDF) for `advise_huge_pages` to act.
        let (w, h) = (1000usize, 600usize);
        let img = random_map(w, h, 71, Some(10));
        for sin_theta in [true, false] {
            let d = build(&img, sin_theta);
            let weights = d.weights();
            let mut total = 0.0;
            for y in 0..h {
                let s = if sin_theta { theta_of_row(y, h).sin() } else { 1.0 };
                let row_sum: f64 = img.row(y).iter().map(|&v| v as f64 * s).sum();
                assert!((d.row_sums[y] - row_sum).abs() <= 1e-13 * row_sum, "row {y}");
                total += row_sum;
                for x in 0..w {
                    let expect = img.data[y * w + x] as f64 * s;
                    let got = d.weight(x, y);
                    assert_eq!(got, weights[y * w + x]);
                    // The interval's ends carry an absolute error of a few 2^-53 of the row sum.
                    assert!((got - expect).abs() <= 1e-9 * expect + 8.0 * f64::EPSILON * row_sum, "({x}, {y})");
                    assert_eq!(got > 0.0, expect > 0.0, "({x}, {y})");
                }
            }
            assert!((d.total - total).abs() <= 1e-12 * total);
        }
    }

    #[test]
    fn a_texel_lost_in_the_running_sum_has_pdf_zero_and_is_never_sampled() {
        // Row 0: a 1e-3 texel after a 1e30 one disappears from the f64 running sum; before it, it
        // keeps its (tiny) probability.
        let img = Image::from_vec(2, 2, 1, vec![1e30, 1e-3, 1e-3, 1e30]);
        let d = build(&img, true);
        assert_eq!(d.texel_probability(1, 0), 0.0);
        assert_eq!(d.pdf(1, 0), 0.0);
        assert!(d.pdf(0, 1) > 0.0 && d.weight(0, 1) > 0.0);
        let mut rng = SplitMix64::new(8);
        for _ in 0..10_000 {
            let (x, y, pdf) = d.sample(rng.next_f64(), rng.next_f64());
            assert!((x, y) != (1, 0) && pdf > 0.0);
        }
    }
}
