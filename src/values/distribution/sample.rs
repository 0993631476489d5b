//! Drawing from a [`Distribution2D`] and evaluating it: the interval search, `sample` (row from
//! the marginal CDF, column from the row's conditional CDF), each texel's probability and the
//! solid-angle pdf, looked up from the same CDFs so that they agree with `sample`.

use super::{Distribution2D, ONE_MINUS_EPSILON};
use crate::geometry::latlong::{texel_of_direction, texel_solid_angle};
use crate::values::Image;

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

impl Distribution2D {
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
