//! `LatLongGrid`: the lat-long convention of [`super::latlong`] precomputed for one W x H map, so
//! that a per-sample loop needs no call to the maths library's trigonometry.
//!
//! - Texel centres: `sin`/`cos` of every row's theta and every column's phi, computed once (with
//!   the same libm calls as `latlong::texel_direction`, so the directions are bit-identical).
//! - Texel edges: `cos(pi y / H)` for the H + 1 row edges and `(sin, cos)(2 pi x / W)` for the
//!   W + 1 column edges. [`LatLongGrid::texel_of`] finds the texel containing a direction by a
//!   cheap guess (polynomial `acos`/`atan2`, Abramowitz and Stegun 4.4.45 and 4.4.49, errors
//!   below 7e-5 and 1.2e-5 rad) corrected against those edges: row y holds `cos(theta)` in
//!   `(edge_{y+1}, edge_y]`, column x holds phi in `[phi_x, phi_{x+1})`, tested by the sign of
//!   `sin(phi - phi_x) sin(theta) = (-d_x) cos(phi_x) - d_z sin(phi_x)`. So the answer does not
//!   depend on the approximations: it is exact with respect to the edge tables, and agrees with
//!   `latlong::texel_of_direction` except for directions within rounding (1e-15) of an edge.
//! - [`sincos_turns`]: `(sin, cos)(2 pi t)` by octant reduction and Taylor polynomials of degree
//!   15/16 on `[0, pi/4]` (truncation below 5e-17; the test checks 1e-15 against libm's
//!   `sin_cos(2 pi t)`, whose argument `2 pi t` is itself rounded by up to 4.4e-16).
//!
//! Why by hand: glam and the standard library offer only libm's scalar `sin_cos`, `acos` and
//! `atan2` (20-100 cycles each); these loops run them billions of times.

use std::f64::consts::{FRAC_PI_4, PI};

use super::latlong;

/// `(sin, cos)(2 pi t)` for `t` in turns (any finite `t`; the fractional part is used). See the
/// module documentation for the accuracy.
#[inline(always)]
pub fn sincos_turns(t: f64) -> (f64, f64) {
    // `floor` is a libm call on baseline x86_64 (no SSE4.1): skip it on the common [0, 1).
    let f = if (0.0..1.0).contains(&t) { t } else { t - t.floor() };
    let e = f * 8.0;
    let octant = (e as usize).min(7);
    let r = e - octant as f64;
    // Angle inside the octant, measured from the octant's even edge.
    let a = if octant & 1 == 0 { r } else { 1.0 - r } * FRAC_PI_4;
    let a2 = a * a;
    // Taylor series of sin and cos, Horner form (coefficients (-1)^k / (2k+1)! and / (2k)!).
    let s = a
        * (1.0
            + a2 * (-1.0 / 6.0
                + a2 * (1.0 / 120.0
                    + a2 * (-1.0 / 5040.0
                        + a2 * (1.0 / 362_880.0
                            + a2 * (-1.0 / 39_916_800.0
                                + a2 * (1.0 / 6_227_020_800.0 + a2 * (-1.0 / 1_307_674_368_000.0))))))));
    let c = 1.0
        + a2 * (-0.5
            + a2 * (1.0 / 24.0
                + a2 * (-1.0 / 720.0
                    + a2 * (1.0 / 40_320.0
                        + a2 * (-1.0 / 3_628_800.0
                            + a2 * (1.0 / 479_001_600.0
                                + a2 * (-1.0 / 87_178_291_200.0 + a2 * (1.0 / 20_922_789_888_000.0))))))));
    // By octant: 0 (s, c), 1 (c, s), 2 (c, -s), 3 (s, -c), 4 (-s, -c), 5 (-c, -s), 6 (-c, s),
    // 7 (-s, c). Chosen with bit masks rather than an 8-way `match`: the octant of a random angle
    // is unpredictable, and the jump table's mispredictions cost more than the polynomials.
    // The same bits as the `match`.
    let o = octant as u64;
    let swap = (((o + 1) >> 1) & 1).wrapping_neg(); // octants 1, 2, 5, 6: all ones
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let first = (cb & swap) | (sb & !swap);
    let second = (sb & swap) | (cb & !swap);
    let sin_sign = (o >> 2) << 63; // octants 4-7
    let cos_sign = (((o + 2) >> 2) & 1) << 63; // octants 2-5
    (f64::from_bits(first ^ sin_sign), f64::from_bits(second ^ cos_sign))
}

/// The direction at azimuth `turns` (in turns) whose `cos(theta)` is the fraction `v` of the
/// way from `c0` to `c1`: `[-sin(theta) sin(phi), cos(theta), sin(theta) cos(phi)]`
/// (`latlong`'s convention, `phi = 2 pi turns`). Pure arithmetic, so a loop of it vectorises.
#[inline(always)]
pub fn point_in_band(turns: f64, c0: f64, c1: f64, v: f64) -> [f64; 3] {
    let (sp, cp) = sincos_turns(turns);
    let ct = c0 + (c1 - c0) * v;
    let st = (1.0 - ct * ct).max(0.0).sqrt();
    [-st * sp, ct, st * cp]
}

/// `acos(x)` within 6.7e-5 rad (Abramowitz and Stegun 4.4.45), for a first guess only.
#[inline(always)]
fn acos_guess(x: f64) -> f64 {
    let a = x.abs().min(1.0);
    let r = (1.0 - a).sqrt() * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261_0 + a * -0.018_729_3)));
    if x < 0.0 {
        PI - r
    } else {
        r
    }
}

/// `atan2(y, x)` in `[0, 2 pi)` within 1.2e-5 rad (A&S state 1e-5 for the polynomial; the
/// reduction's rounding adds a little) (Abramowitz and Stegun 4.4.49 after reduction
/// to `[0, 1]`), for a first guess only. `(0, 0)` gives 0.
#[inline(always)]
fn atan2_guess(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ax < ay { (ax, ay) } else { (ay, ax) };
    if hi == 0.0 {
        return 0.0;
    }
    let t = lo / hi;
    let t2 = t * t;
    let mut a = t * (0.999_866_0 + t2 * (-0.330_299_5 + t2 * (0.180_141_0 + t2 * (-0.085_133_0 + t2 * 0.020_835_1))));
    if ay > ax {
        a = PI / 2.0 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 {
        a = 2.0 * PI - a;
    }
    a
}

/// The lat-long convention precomputed for one map size (see the module documentation).
#[derive(Clone, Debug)]
pub struct LatLongGrid {
    pub width: usize,
    pub height: usize,
    /// `sin` and `cos` of each row centre's theta (H entries each).
    row_sin: Vec<f64>,
    row_cos: Vec<f64>,
    /// `sin` and `cos` of each column centre's phi (W entries each).
    col_sin: Vec<f64>,
    col_cos: Vec<f64>,
    /// `cos(pi y / H)`, y = 0..=H (1 down to -1, exact at both ends).
    row_edge_cos: Vec<f64>,
    /// `sin` and `cos` of `2 pi x / W`, x = 0..=W (exact (0, 1) at both ends).
    col_edge_sin: Vec<f64>,
    col_edge_cos: Vec<f64>,
    /// Midpoint-rule solid angle of a texel of each row, `(2 pi / W)(pi / H) sin(theta_y)`,
    /// as `latlong::texel_solid_angle`.
    midpoint_solid_angle: Vec<f64>,
    /// Exact solid angle of a texel of each row, `(2 pi / W)(cos theta_top - cos theta_bottom)`.
    exact_solid_angle: Vec<f64>,
}

impl LatLongGrid {
    /// The tables for a W x H map (O(W + H) libm calls).
    pub fn new(width: usize, height: usize) -> LatLongGrid {
        let (w, h) = (width.max(1), height.max(1));
        let thetas: Vec<f64> = (0..height).map(|y| latlong::theta_of_row(y, h)).collect();
        let phis: Vec<f64> = (0..width).map(|x| latlong::phi_of_column(x, w)).collect();
        let mut row_edge_cos: Vec<f64> = (0..=height).map(|y| (PI * y as f64 / h as f64).cos()).collect();
        row_edge_cos[0] = 1.0;
        row_edge_cos[height] = -1.0;
        let mut col_edge_sin: Vec<f64> = (0..=width).map(|x| (2.0 * PI * x as f64 / w as f64).sin()).collect();
        let mut col_edge_cos: Vec<f64> = (0..=width).map(|x| (2.0 * PI * x as f64 / w as f64).cos()).collect();
        (col_edge_sin[0], col_edge_cos[0], col_edge_sin[width], col_edge_cos[width]) = (0.0, 1.0, 0.0, 1.0);
        let dphi = 2.0 * PI / w as f64;
        LatLongGrid {
            width,
            height,
            row_sin: thetas.iter().map(|t| t.sin()).collect(),
            row_cos: thetas.iter().map(|t| t.cos()).collect(),
            col_sin: phis.iter().map(|p| p.sin()).collect(),
            col_cos: phis.iter().map(|p| p.cos()).collect(),
            midpoint_solid_angle: (0..height).map(|y| latlong::texel_solid_angle(y, w, h)).collect(),
            exact_solid_angle: (0..height).map(|y| dphi * (row_edge_cos[y] - row_edge_cos[y + 1])).collect(),
            row_edge_cos,
            col_edge_sin,
            col_edge_cos,
        }
    }

    /// Unit direction of texel (x, y)'s centre, bit-identical to `latlong::texel_direction`.
    #[inline]
    pub fn centre_direction(&self, x: usize, y: usize) -> [f64; 3] {
        let (st, ct) = (self.row_sin[y], self.row_cos[y]);
        [-st * self.col_sin[x], ct, st * self.col_cos[x]]
    }

    /// The point of texel (x, y) at fractions `(u, v)` uniform in solid angle: phi uniform across
    /// the column, `cos(theta)` uniform between the row's edges ([`point_in_band`]).
    #[inline(always)]
    pub fn point_in_texel(&self, x: usize, y: usize, u: f64, v: f64) -> [f64; 3] {
        let (c0, c1) = self.row_edges_cos(y);
        point_in_band(self.turns_in_column(x, u), c0, c1, v)
    }

    /// `cos(theta)` at row `y`'s top and bottom edges.
    #[inline(always)]
    pub fn row_edges_cos(&self, y: usize) -> (f64, f64) {
        (self.row_edge_cos[y], self.row_edge_cos[y + 1])
    }

    /// The azimuth, in turns, at fraction `u` across column `x`: `(x + u) / W`.
    #[inline(always)]
    pub fn turns_in_column(&self, x: usize, u: f64) -> f64 {
        (x as f64 + u) / self.width as f64
    }

    /// Midpoint-rule solid angle of a texel of row `y`.
    #[inline]
    pub fn midpoint_solid_angle(&self, y: usize) -> f64 {
        self.midpoint_solid_angle[y]
    }

    /// Exact solid angle of a texel of row `y`.
    #[inline]
    pub fn exact_solid_angle(&self, y: usize) -> f64 {
        self.exact_solid_angle[y]
    }

    /// The texel containing unit direction `d` (see the module documentation); always in range
    /// for a non-empty grid. Falls back to `latlong::texel_of_direction` for grids narrower than
    /// 8 columns (where the sign test's one-sided assumption fails) and if the correction does
    /// not settle in four steps (never seen; a guard, not a path).
    #[inline(always)]
    pub fn texel_of(&self, d: [f64; 3]) -> (usize, usize) {
        self.texel_from_guess(d, self.texel_guess(d))
    }

    /// The first half of [`Self::texel_of`]: the polynomial guesses of the row and column, as
    /// `[acos(y) H / pi, atan2(-x, z) W / (2 pi)]`. Arithmetic only, so a loop of it
    /// vectorises; [`Self::texel_from_guess`] corrects them against the edge tables.
    #[inline(always)]
    pub fn texel_guess(&self, d: [f64; 3]) -> [f64; 2] {
        let cy = d[1].clamp(-1.0, 1.0);
        [acos_guess(cy) * (self.height as f64 / PI), atan2_guess(-d[0], d[2]) * (self.width as f64 / (2.0 * PI))]
    }

    /// The second half of [`Self::texel_of`]: the texel containing `d`, from `guess =`
    /// [`Self::texel_guess`]`(d)` corrected exactly against the edge tables.
    #[inline(always)]
    pub fn texel_from_guess(&self, d: [f64; 3], guess: [f64; 2]) -> (usize, usize) {
        let (w, h) = (self.width, self.height);
        if w < 8 || h == 0 {
            return latlong::texel_of_direction(d, w, h);
        }
        let cy = d[1].clamp(-1.0, 1.0);
        let mut y = (guess[0] as usize).min(h - 1);
        let mut settled = false;
        for _ in 0..4 {
            if cy > self.row_edge_cos[y] && y > 0 {
                y -= 1;
            } else if cy <= self.row_edge_cos[y + 1] && y + 1 < h {
                y += 1;
            } else {
                settled = true;
                break;
            }
        }
        let (s, c) = (-d[0], d[2]);
        if s == 0.0 && c == 0.0 {
            // A pole: phi = 0 by `latlong::angles`' convention.
            return if settled { (0, y) } else { latlong::texel_of_direction(d, w, h) };
        }
        let mut x = (guess[1] as usize).min(w - 1);
        let cross = |j: usize| s * self.col_edge_cos[j] - c * self.col_edge_sin[j];
        for _ in 0..4 {
            if cross(x) < 0.0 {
                x = if x == 0 { w - 1 } else { x - 1 };
            } else if cross(x + 1) >= 0.0 {
                x = if x + 1 == w { 0 } else { x + 1 };
            } else {
                return if settled { (x, y) } else { latlong::texel_of_direction(d, w, h) };
            }
        }
        latlong::texel_of_direction(d, w, h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn next(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn sincos_turns_matches_libm() {
        let mut st = 1u64;
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            let t = if i < 16 { i as f64 / 16.0 } else { next(&mut st) };
            let (s, c) = sincos_turns(t);
            let (es, ec) = (2.0 * PI * t).sin_cos();
            worst = worst.max((s - es).abs()).max((c - ec).abs());
        }
        assert!(worst < 1e-15, "worst error {worst:e}");
        assert_eq!(sincos_turns(0.0), (0.0, 1.0));
        let (s, c) = sincos_turns(1.25);
        assert!((s - 1.0).abs() < 1e-16 && c.abs() < 1e-16);
    }

    #[test]
    fn guesses_are_within_their_stated_error() {
        let mut st = 2u64;
        for _ in 0..100_000 {
            let x = 2.0 * next(&mut st) - 1.0;
            assert!((acos_guess(x) - x.acos()).abs() < 6.8e-5, "{x}");
            let (a, b) = (2.0 * next(&mut st) - 1.0, 2.0 * next(&mut st) - 1.0);
            let mut want = a.atan2(b);
            if want < 0.0 {
                want += 2.0 * PI;
            }
            let got = atan2_guess(a, b);
            let diff = (got - want).abs().min(2.0 * PI - (got - want).abs());
            assert!(diff < 1.2e-5, "{a} {b}: {got} vs {want}");
        }
    }

    /// The fast lookup agrees with `latlong::texel_of_direction` on random directions, on
    /// directions at texel centres and within 1e-9 of every edge, on several map sizes.
    #[test]
    fn texel_of_agrees_with_the_libm_lookup() {
        let mut st = 3u64;
        for (w, h) in [(8, 4), (16, 8), (64, 32), (1024, 512), (4000, 1999), (16384, 8192)] {
            let grid = LatLongGrid::new(w, h);
            let mut disagreements = 0;
            for _ in 0..50_000 {
                let z = 1.0 - 2.0 * next(&mut st);
                let r = (1.0 - z * z).sqrt();
                let (s, c) = (2.0 * PI * next(&mut st)).sin_cos();
                let d = [r * c, z, r * s];
                if grid.texel_of(d) != latlong::texel_of_direction(d, w, h) {
                    disagreements += 1;
                }
            }
            assert_eq!(disagreements, 0, "{w}x{h}");
            for _ in 0..2000 {
                let x = (next(&mut st) * w as f64) as usize;
                let y = (next(&mut st) * h as f64) as usize;
                assert_eq!(grid.texel_of(grid.centre_direction(x, y)), (x, y));
                assert_eq!(grid.centre_direction(x, y), latlong::texel_direction(x, y, w, h));
                // Just inside each corner of the texel.
                for (fu, fv) in [(1e-9, 1e-9), (1.0 - 1e-9, 1e-9), (1e-9, 1.0 - 1e-9), (1.0 - 1e-9, 1.0 - 1e-9)] {
                    let p = grid.point_in_texel(x, y, fu, fv);
                    assert_eq!(grid.texel_of(p), (x, y), "{w}x{h} texel ({x}, {y}) at ({fu}, {fv})");
                }
            }
        }
    }

    #[test]
    fn poles_and_tiny_grids() {
        let grid = LatLongGrid::new(32, 16);
        assert_eq!(grid.texel_of([0.0, 1.0, 0.0]), (0, 0));
        assert_eq!(grid.texel_of([0.0, -1.0, 0.0]), (0, 15));
        for (w, h) in [(1, 1), (3, 2), (7, 3)] {
            let g = LatLongGrid::new(w, h);
            for d in [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.6, -0.8, 0.0]] {
                assert_eq!(g.texel_of(d), latlong::texel_of_direction(d, w, h));
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_the_sphere() {
        let grid = LatLongGrid::new(64, 32);
        let exact: f64 = (0..32).map(|y| 64.0 * grid.exact_solid_angle(y)).sum();
        let mid: f64 = (0..32).map(|y| 64.0 * grid.midpoint_solid_angle(y)).sum();
        assert!((exact - 4.0 * PI).abs() < 1e-12);
        assert!((mid / (4.0 * PI) - 1.0).abs() < 1e-3);
    }
}
