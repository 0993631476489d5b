//! Footprint means of a lat-long map over the cells of another layout by cut cells: the quadrature
//! of a rotated lat-long map ([`crate::maths::resample::rotation::rotate_latlong`]) and of the disc
//! images (`maths::resample::disc_image::to_disc`), the same means as the adaptive midpoint
//! subdivision of `maths::resample::layouts` to the same tolerance, with tens of times fewer lookups.
//!
//! Each output texel (here a rotated lat-long texel `[phi0, phi1] x [theta0, theta1]`) gets
//! `(1 / Omega) * integral of L(R^T w) dw` over its footprint, the source `L` piecewise constant on
//! its texels. The subdivision in the output's parameters (corners and centre looked up, shared
//! between cells) is that of `layouts`, but a cell is integrated *exactly up to the curvature of
//! the source's texel boundaries across it* instead of being split down to 1/4096 of a texel:
//!
//! - The source's texel boundaries are straight lines in its own angles (`theta_s = k pi / H`,
//!   `phi_s = k 2 pi / W`). Over a cell, in cell coordinates `(u, v)` in `[-1/2, 1/2]^2`, `theta_s`
//!   and `phi_s` (unwrapped about the centre's) are each fitted by a plane `a + b u + c v` from
//!   their values at the corners and centre (`b`, `c` the corner differences;
//!   `a = (2 g_centre + mean of corners) / 3`, exact for the mean of a quadratic). A yaw moves
//!   `phi_s` linearly: then the planes are exact.
//! - The texels the planes reach over the square, widened by their `bend` (below), are at most
//!   `MAX_TEXELS`; texel (row, col) weighs `C(row, col) - C(row - 1, col) - C(row, col - 1) +
//!   C(row - 1, col - 1)`, `C(i, j)` the part of the unit square in rows up to i and columns up to
//!   j (Sutherland-Hodgman clips, none where a line misses the part) weighted by the solid-angle
//!   density across the cell taken linear (`Footprint::slopes`; `sin theta` for a lat-long cell).
//!   The weights of a cell sum to 1, so its solid angle is kept exactly and a constant map stays
//!   constant.
//! - Error: a plane misplaces each boundary by at most `bend / |grad|` cell sides, `bend =
//!   |g_centre - mean of corners| + |g00 - g10 - g01 + g11| / 4` (the curvature and twist the plane
//!   leaves out), so the cell's error is below `spread * Omega * sqrt(2) * sum over the boundaries
//!   of bend / |grad|` (`spread` the largest channel difference of its texels). A cell splits while
//!   that exceeds `tol`, as a midpoint leaf of `layouts` splits while `spread * Omega > tol`; the
//!   bound shrinks as the cube of the cell's size. The bound needs only the planes and the texels'
//!   values, so a cell to be split is not clipped, and a cell over texels all alike not at all.
//!
//! A cell larger than a source texel (a mirror ball's rim pixels) is cut directly when the planes
//! hold there; a cell over more texels, or across the domain's edge (a disc's rim), is split as in
//! `layouts::integrate` and, at the depth limit, takes the source texel at its centre. Tested
//! against brute-force footprint means, the midpoint subdivision and the sphere integral (`tests`,
//! and `disc_image`'s tests).
//!
//! Speed: the source angles come from `resample::angles` (a polynomial `atan2`, 2e-15 rad, not
//! libm's `acos` and `atan2`); a rotated lat-long map's rows share their edges' grid points; a
//! cell more than twice as long as wide in the source's angles (a mirror ball's rim pixels,
//! long radially and thin tangentially, or a lat-long texel near a pole) is halved across its
//! length only, its depth still counting the halvings of its longest extent; a row's cells share
//! their solid angle's and density's cosines; a row's grid points take their angles four at a
//! time with AVX2 (`angles::lanes`, the same bits); a cut stops at its first row wholly kept,
//! skips the columns past one wholly kept, and clips into buffers instead of copying polygons.

use std::f64::consts::{PI, SQRT_2, TAU};

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::maths::resample::angles;
use crate::maths::resample::layouts::{normalised, Footprint, LatLongDomain, LatLongSource, Limits};
use crate::maths::resample::polygon::Line;
use crate::values::Image;

/// A grid point of the subdivision: its polar angle and azimuth in the source, and its source
/// texel.
#[derive(Clone, Copy)]
struct Pt {
    theta: f64,
    phi: f64,
    col: usize,
    row: usize,
}

/// The tolerance of `Rotate`'s cut cells: a cell's error bound below this share of the map's
/// magnitude (module docs). Measured on the tests' noise map against the brute force, worst and
/// mean relative difference: 4.2e-5 and 8.8e-6 at 1e-9, 2e-9 and 4e-9 alike; 1.1e-4 and 1.4e-5
/// at 1e-8, over the bar of 6.9e-5. A rotation of a 1k map integrates 29% fewer cells
/// at 4e-9 than at 1e-9.
pub const ROTATION_TOLERANCE: f64 = 4e-9;

/// Rows of a rotated lat-long map computed together, sharing their edges' corners.
const BAND: usize = 8;

/// The most source texels a cut cell may cover (more are split first).
const MAX_TEXELS: usize = 64;

/// A cut of a cell: the planes fitted to the source's angles over it, the source texels they
/// reach, and the factor `bend` of its error bound `spread * Omega * bend`.
struct Plan {
    /// `theta_s`, and `phi_s - phi0` (unwrapped about the centre's azimuth `phi0`).
    t: Line,
    f: Line,
    phi0: f64,
    rows: (isize, isize),
    cols: (isize, isize),
    /// `sqrt(2)` times the boundaries' largest misplacements, in cell sides.
    bend: f64,
}

/// What a cell's caller already has: its centre's grid point, solid angle and density slopes
/// (`Footprint::slopes`); a rotated lat-long map's rows share the last two.
#[derive(Clone, Copy)]
struct Known {
    centre: Pt,
    omega: f64,
    beta: [f64; 2],
}

/// `x.floor() as isize` without a call to libm's `floor` (which the baseline x86-64 target
/// cannot inline): the same value for every f64, NaN giving 0 and the infinities saturating.
#[inline]
fn floor_i(x: f64) -> isize {
    let i = x as isize;
    if (i as f64) > x {
        i.saturating_sub(1)
    } else {
        i
    }
}

/// An azimuth difference wrapped to [-pi, pi].
#[inline]
fn wrap(d: f64) -> f64 {
    if d > PI {
        d - TAU
    } else if d < -PI {
        d + TAU
    } else {
        d
    }
}

/// The angle between two grid points, to first order (`d theta` and `sin theta d phi`): a
/// cell's extent for choosing how to split it.
#[inline]
fn extent(a: Pt, b: Pt) -> f64 {
    let along = (0.5 * (a.theta + b.theta)).sin() * wrap(a.phi - b.phi);
    let across = a.theta - b.theta;
    (along * along + across * across).sqrt()
}

/// A lat-long source seen through `R^T` from the cells of a footprint parametrisation, with the
/// tables of the source's texel boundaries.
pub(crate) struct Cells<'a, 'b, F: Footprint> {
    src: &'a LatLongSource<'b>,
    fp: &'a F,
    inverse: DMat3,
    w: usize,
    h: usize,
    /// Rows and columns a radian: `H / pi`, `W / (2 pi)`.
    per_dt: f64,
    per_df: f64,
}

impl<'a, 'b, F: Footprint> Cells<'a, 'b, F> {
    pub(crate) fn new(src: &'a LatLongSource<'b>, fp: &'a F, inverse: DMat3) -> Self {
        let (w, h) = src.size();
        Cells { src, fp, inverse, w, h, per_dt: h as f64 / PI, per_df: w as f64 / TAU }
    }

    /// The solid-angle mean of the source over the cell `r = [p0, p1, q0, q1]`.
    pub(crate) fn average(&self, r: [f64; 4], lim: &Limits) -> [f32; 3] {
        let [p0, p1, q0, q1] = r;
        let corners = [(p0, q0), (p1, q0), (p0, q1), (p1, q1)].map(|(p, q)| self.point(p, q));
        self.average_from(r, corners, None, lim)
    }

    fn average_from(&self, r: [f64; 4], corners: [Pt; 4], known: Option<Known>, lim: &Limits) -> [f32; 3] {
        let (mut acc, mut weight) = ([0.0; 3], 0.0);
        self.integrate(r, corners, known, 0, lim, &mut acc, &mut weight);
        normalised(acc, weight)
    }

    /// The grid point at (p, q); its angles are `latlong::angles`' to 2e-15 rad
    /// (`resample::angles`), its texel `latlong::texel_of_direction`'s but within that of a
    /// boundary.
    fn point(&self, p: f64, q: f64) -> Pt {
        self.point_towards(self.fp.dir(p, q))
    }

    /// The grid point whose footprint direction is `d`.
    fn point_towards(&self, d: DVec3) -> Pt {
        let s = self.inverse * d;
        let (theta, phi) = angles::latlong_angles(s.into());
        self.point_at(theta, phi)
    }

    /// The grid point at source angles (theta, phi).
    #[inline]
    fn point_at(&self, theta: f64, phi: f64) -> Pt {
        let col = floor_i(phi * self.per_df);
        let row = floor_i(theta * self.per_dt);
        let (col, row) = (col.clamp(0, self.w as isize - 1) as usize, row.clamp(0, self.h as isize - 1) as usize);
        Pt { theta, phi, col, row }
    }

    #[inline]
    fn value(&self, col: usize, row: usize) -> [f64; 3] {
        self.src.texel_rgb(col, row).map(f64::from)
    }

    /// The plane fitted to `g` over the cell, the largest distance of `g` from it (its curvature and
    /// twist), and the plane's gradient (per cell side).
    fn fit(g: [f64; 5]) -> (Line, f64, f64) {
        let [g00, g10, g01, g11, gm] = g;
        let mean = 0.25 * (g00 + g10 + g01 + g11);
        let line =
            Line { a: (2.0 * gm + mean) / 3.0, b: 0.5 * (g10 - g00 + g11 - g01), c: 0.5 * (g01 - g00 + g11 - g10) };
        let bend = (gm - mean).abs() + 0.25 * (g00 - g10 - g01 + g11).abs();
        (line, bend, (line.b * line.b + line.c * line.c).sqrt())
    }

    /// Adds the integral over the cell `r` to `acc` and its solid angle to `weight`; `known`, the
    /// cell's centre, solid angle and density slopes when the caller has them.
    #[allow(clippy::too_many_arguments)]
    fn integrate(
        &self,
        r: [f64; 4],
        corners: [Pt; 4],
        known: Option<Known>,
        depth: u32,
        lim: &Limits,
        acc: &mut [f64; 3],
        weight: &mut f64,
    ) {
        let [p0, p1, q0, q1] = r;
        let (m, omega) = match known {
            Some(k) => (k.centre, k.omega),
            None => (self.point(0.5 * (p0 + p1), 0.5 * (q0 + q1)), self.fp.solid_angle(p0, p1, q0, q1)),
        };
        let pts = [corners[0], corners[1], corners[2], corners[3], m];
        let same = pts.iter().all(|t| t.col == m.col && t.row == m.row);
        // Below the forced depth (a cell larger than a source texel), five points in one texel
        // do not show that the cell is in it: the cut's planes, with their margin, do.
        if !same || depth < lim.forced {
            let plan = if self.fp.whole(r) { self.plan(&pts) } else { None };
            match plan {
                Some(plan) => {
                    let (spread, first) = self.spread(&plan);
                    let mean = if spread == 0.0 {
                        first
                    } else if spread * omega * plan.bend <= lim.tol || depth >= lim.max {
                        let beta = known.map_or_else(|| self.fp.slopes(r, omega), |k| k.beta);
                        self.cut_mean(&plan, beta)
                    } else {
                        return self.split(r, corners, m, depth, lim, acc, weight);
                    };
                    for (a, m) in acc.iter_mut().zip(mean) {
                        *a += m * omega;
                    }
                    *weight += omega;
                    return;
                }
                None if depth < lim.forced => return self.split(r, corners, m, depth, lim, acc, weight),
                None if depth < lim.max => {
                    // Too many texels, or across the domain's edge: `layouts::integrate`'s rule.
                    let vm = self.value(m.col, m.row);
                    let mut spread = 0.0f64;
                    let mut scale = vm.iter().fold(0.0f64, |s, v| s.max(v.abs()));
                    for t in corners {
                        let v = self.value(t.col, t.row);
                        for k in 0..3 {
                            spread = spread.max((v[k] - vm[k]).abs());
                            scale = scale.max(v[k].abs());
                        }
                    }
                    if (depth < lim.boundary && spread > 1e-2 * scale) || spread * omega > lim.tol {
                        return self.split(r, corners, m, depth, lim, acc, weight);
                    }
                }
                None => {}
            }
        }
        let v = self.value(m.col, m.row);
        for k in 0..3 {
            acc[k] += v[k] * omega;
        }
        *weight += omega;
    }

    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        r: [f64; 4],
        corners: [Pt; 4],
        m: Pt,
        depth: u32,
        lim: &Limits,
        acc: &mut [f64; 3],
        weight: &mut f64,
    ) {
        let [p0, p1, q0, q1] = r;
        let (pm, qm) = (0.5 * (p0 + p1), 0.5 * (q0 + q1));
        let [c00, c10, c01, c11] = corners;
        // A cell more than twice as long (in the source's angles) one way as the other, like a
        // mirror ball's rim pixels, is halved across its length only: its longest extent halves
        // as in a split into four, with half the cells.
        let (along_p, along_q) = (extent(c00, c10) + extent(c01, c11), extent(c00, c01) + extent(c10, c11));
        if along_p > 2.0 * along_q {
            let (eb, et) = (self.point(pm, q0), self.point(pm, q1));
            self.integrate([p0, pm, q0, q1], [c00, eb, c01, et], None, depth + 1, lim, acc, weight);
            return self.integrate([pm, p1, q0, q1], [eb, c10, et, c11], None, depth + 1, lim, acc, weight);
        }
        if along_q > 2.0 * along_p {
            let (el, er) = (self.point(p0, qm), self.point(p1, qm));
            self.integrate([p0, p1, q0, qm], [c00, c10, el, er], None, depth + 1, lim, acc, weight);
            return self.integrate([p0, p1, qm, q1], [el, er, c01, c11], None, depth + 1, lim, acc, weight);
        }
        let (eb, el, er, et) = (self.point(pm, q0), self.point(p0, qm), self.point(p1, qm), self.point(pm, q1));
        for (rr, cc) in [
            ([p0, pm, q0, qm], [c00, eb, el, m]),
            ([pm, p1, q0, qm], [eb, c10, m, er]),
            ([p0, pm, qm, q1], [el, m, c01, et]),
            ([pm, p1, qm, q1], [m, er, et, c11]),
        ] {
            self.integrate(rr, cc, None, depth + 1, lim, acc, weight);
        }
    }

    /// The planes of a cell's cut and the texels they reach (module docs); `None` for a cell over
    /// more than `MAX_TEXELS` source texels.
    fn plan(&self, pts: &[Pt; 5]) -> Option<Plan> {
        let m = pts[4];
        let (t, t_bend, t_grad) = Self::fit(pts.map(|p| p.theta));
        let (f, f_bend, f_grad) = Self::fit(pts.map(|p| wrap(p.phi - m.phi)));
        // The rows and columns the planes cover over the square, and those within their bend.
        let t_half = 0.5 * (t.b.abs() + t.c.abs()) + t_bend;
        let f_half = 0.5 * (f.b.abs() + f.c.abs()) + f_bend;
        let last_row = self.h as isize - 1;
        let row0 = floor_i((t.a - t_half) * self.per_dt).clamp(0, last_row);
        let row1 = floor_i((t.a + t_half) * self.per_dt).clamp(0, last_row);
        let col0 = floor_i((m.phi + f.a - f_half) * self.per_df);
        let col1 = floor_i((m.phi + f.a + f_half) * self.per_df);
        let (rows, cols) = ((row1 - row0 + 1) as usize, (col1 - col0 + 1) as usize);
        if rows * cols > MAX_TEXELS || cols > self.w {
            return None;
        }
        let misplaced = |n: usize, bend: f64, grad: f64| {
            if n <= 1 {
                0.0
            } else if grad > 0.0 {
                (n - 1) as f64 * bend / grad
            } else {
                f64::INFINITY
            }
        };
        let bend = SQRT_2 * (misplaced(rows, t_bend, t_grad) + misplaced(cols, f_bend, f_grad));
        Some(Plan { t, f, phi0: m.phi, rows: (row0, row1), cols: (col0, col1), bend })
    }

    /// The texel (col, row) of a plan, its column wrapped.
    #[inline]
    fn value_at(&self, col: isize, row: isize) -> [f64; 3] {
        let w = self.w as isize;
        // No division but across the azimuth's seam.
        let col = if (0..w).contains(&col) { col } else { col.rem_euclid(w) };
        self.value(col as usize, row as usize)
    }

    /// The largest channel difference of the texels a plan reaches, and its first texel.
    fn spread(&self, plan: &Plan) -> (f64, [f64; 3]) {
        let first = self.value_at(plan.cols.0, plan.rows.0);
        let (mut lo, mut hi) = (first, first);
        for row in plan.rows.0..=plan.rows.1 {
            for col in plan.cols.0..=plan.cols.1 {
                let v = self.value_at(col, row);
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
        }
        ((0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max), first)
    }
}

/// The W x H RGB lat-long image whose texels average `src` seen through `inverse` (`R^T`) over
/// their footprints, each cell's error below `rel_tol` times the source's magnitude, cells down
/// to `2^-depth` of a source texel (module docs).
pub fn rotated_latlong(src: &LatLongSource, inverse: DMat3, rel_tol: f64, depth: u32) -> Image {
    let (w, h) = src.size();
    let cells = Cells::new(src, &LatLongDomain, inverse);
    let lim = Limits::with_tolerance(src, PI / h as f64, rel_tol, depth);
    let mut out = Image::new(w, h, 3);
    let (dp, dq) = (TAU / w as f64, PI / h as f64);
    // (sin, cos) of the columns' edges (2k) and centres (2k + 1), shared by every row.
    let columns: Vec<(f64, f64)> = (0..=2 * w).map(|k| (0.5 * dp * k as f64).sin_cos()).collect();
    let level = crate::cpu::level();
    let points = |q: f64, parity: usize| -> Vec<Pt> {
        let (st, ct) = q.sin_cos();
        let dirs: Vec<[f64; 3]> = (0..w + 1 - parity)
            .map(|x| {
                let (sp, cp) = columns[2 * x + parity];
                (inverse * DVec3::new(-st * sp, ct, st * cp)).into()
            })
            .collect();
        let mut angles = vec![(0.0, 0.0); dirs.len()];
        angles::lanes::latlong_angles_into(level, &dirs, &mut angles);
        angles.into_iter().map(|(theta, phi)| cells.point_at(theta, phi)).collect()
    };
    // Bands of rows, each row's bottom edge the next one's top: one row of corners a row.
    out.data.par_chunks_mut(3 * w * BAND).enumerate().for_each(|(band, rows)| {
        let mut top = points(dq * (band * BAND) as f64, 0);
        for (i, row) in rows.chunks_mut(3 * w).enumerate() {
            let y = band * BAND + i;
            let (q0, q1) = (dq * y as f64, dq * (y + 1) as f64);
            let (bottom, centres) = (points(q1, 0), points(0.5 * (q0 + q1), 1));
            // `LatLongDomain::solid_angle` and `slopes` of the row's cells, their cosines once.
            let (c0, cm, c1) = (q0.cos(), (0.5 * (q0 + q1)).cos(), q1.cos());
            let beta = [0.0, if c0 > c1 { 4.0 * ((cm - c1) - (c0 - cm)) / (c0 - c1) } else { 0.0 }];
            for x in 0..w {
                let r = [dp * x as f64, dp * (x + 1) as f64, q0, q1];
                let corners = [top[x], top[x + 1], bottom[x], bottom[x + 1]];
                let known = Known { centre: centres[x], omega: (r[1] - r[0]) * (c0 - c1), beta };
                row[3 * x..3 * x + 3].copy_from_slice(&cells.average_from(r, corners, Some(known), &lim));
            }
            top = bottom;
        }
    });
    out
}

mod cut;
#[cfg(test)]
mod tests;
