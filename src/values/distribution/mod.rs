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

//!
//! Files: this one builds the distribution; `sample` draws from it and evaluates its pdf;
//! `codec` is its value type and cache encoding; `row_kernels` writes the rows' CDFs.

mod codec;
pub(crate) mod row_kernels;
mod sample;
#[cfg(test)]
mod tests;

pub use codec::DISTRIBUTION;
pub(crate) use sample::clamp_unit;
pub use sample::pdf_image;

use rayon::prelude::*;

use super::image::Image;
use crate::cpu::{self, Level};
use crate::geometry::latlong::{texel_solid_angle, theta_of_row};
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

    /// Approximate heap plus inline size in bytes.
    pub fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + 8 * (self.conditional_cdf.len() + self.row_sums.len() + self.marginal_cdf.len())
    }
}
