//! The `Area` filter of a camera view: each pixel the solid-angle mean of a lat-long map, read
//! as piecewise constant, over the pixel's footprint,
//! `(1 / Omega(P)) integral over P of L(R c(x, y)) dOmega`.
//!
//! In the map's texel coordinates `(u, v) = (W phi / 2 pi, H theta / pi)` (texel (i, j) is the
//! square `[i, i + 1] x [j, j + 1]`) the solid angle is `dOmega = (2 pi / W)(pi / H) sin(theta)
//! du dv`, and a small plane cell's footprint is nearly the octagon of its corners' and edge
//! midpoints' `(u, v)`. A cell of the pixel is integrated **exactly as that octagon**: clipped
//! against every texel it overlaps (Sutherland-Hodgman), each piece weighted by its area times
//! `sin(theta)` at its centroid (the midpoint rule within a texel: relative error
//! `O(texel^2)`). Where the lens has an exact rectangle solid angle (perspective,
//! orthographic: `Lens::rect_solid_angle`) the cell gets that, shared among its pieces in
//! those proportions. A cell is taken as an octagon when
//!
//! - its corners, edge midpoints and centre all have rays (inside a fisheye's circle);
//! - it spans at most [`MAX_SPAN`] texels in u and in v (a cell near a pole spans many
//!   columns; the seam is unwrapped);
//! - it is flat: each edge midpoint lies within `4 FLATNESS` times the span of the chord
//!   between the edge's ends (so the octagon's half-edges, whose deviation is about a quarter
//!   of that, misplace about [`FLATNESS`] of the cell), or all nine points fall in one texel.
//!
//! Otherwise it is split in four in the plane, down to 2^-3 of a source texel's angle, where a
//! small cell is clipped flat or not (weighted by the lens's solid angle); near a pole, and on
//! the rim of an orthographic disc (whose Jacobian is singular), 3 levels further; across a
//! fisheye's circle down to 2^-6 of the pixel. A cell still not clipped there is a leaf: the
//! texel at its centre's (clamped) ray, weighted by `Lens::rect_solid_angle`. A cell none of
//! whose nine points has a ray, and whose solid angle is 0 to rounding, is beyond the circle or
//! disc and is dropped. The weights are normalised per pixel, so a constant map stays exactly
//! constant; a pixel with no weight is 0. Pixel corners are computed once for the whole view.
//!
//! Why not `maths::resample::layouts`: it integrates footprints by bisecting towards texel edges until
//! a tolerance is met, and for a view finer than the map (every dataset crop) that resolves
//! each edge crossing a pixel with hundreds of leaves (docs/src/guides/toolkit/camera.md has the times),
//! where one octagon is exact.
//!
//! The tests check the result against the exact means of a map of four constant quadrants
//! (spherical polygons, Van Oosterom and Strackee's triangle formula) to 5e-4 (values 1 to 4),
//! and against a brute force of 384 x 384 sub-rays per pixel on texel noise (values 1 to 2)
//! to 1e-3 inside the circle or disc and 1e-2 on its rim (docs/src/guides/toolkit/camera.md has the
//! measured numbers).

use std::f64::consts::PI;

use glam::DMat3;
use rayon::prelude::*;

use crate::geometry::latlong;
use crate::geometry::lens::{Lens, Model};
use crate::values::Image;

/// The largest span, in texels along u and along v, of a cell clipped as an octagon.
pub const MAX_SPAN: f64 = 2.0;
/// How far (relative to the cell's span) the octagon's edges may lie from the footprint's.
pub const FLATNESS: f64 = 1e-3;
/// Splitting goes this many levels below the source texel's size.
const EXTRA_DEPTH: i32 = 3;
/// A cell the fisheye's circle crosses is split this many levels below the pixel.
const RIM_DEPTH: i32 = 6;
/// A cell too wide to clip (near a pole), or crossed by the orthographic disc's rim (where the
/// Jacobian is singular), may go this many levels below the depth limit.
const POLE_DEPTH: i32 = 3;

/// A plane point and where its ray meets the map, in texel coordinates (`None`: no ray).
#[derive(Clone, Copy)]
struct Point {
    x: f64,
    y: f64,
    uv: Option<[f64; 2]>,
}

struct View<'a> {
    env: &'a Image,
    lens: &'a Lens,
    r: DMat3,
}

impl View<'_> {
    fn point(&self, x: f64, y: f64) -> Point {
        let (w, h) = (self.env.width as f64, self.env.height as f64);
        let uv = self.lens.ray(x, y).map(|c| {
            let (theta, phi) = latlong::angles((self.r * c).into());
            [phi / (2.0 * PI) * w, theta / PI * h]
        });
        Point { x, y, uv }
    }

    /// Adds the cell `[p00, p10, p01, p11]` (corners at (x0, y0), (x1, y0), (x0, y1), (x1, y1))
    /// to `acc` (per channel, radiance times solid angle) and `weight` (solid angle).
    fn cell(&self, c: [Point; 4], depth: i32, max_depth: i32, acc: &mut [f64], weight: &mut f64) {
        let [p00, p10, p01, p11] = c;
        let (xm, ym) = (0.5 * (p00.x + p11.x), 0.5 * (p00.y + p11.y));
        let (eb, el, er, et) =
            (self.point(xm, p00.y), self.point(p00.x, ym), self.point(p11.x, ym), self.point(xm, p11.y));
        let centre = self.point(xm, ym);
        let all = [p00, p10, p01, p11, eb, el, er, et, centre];
        let omega = || self.lens.rect_solid_angle(p00.x, p11.x, p00.y, p11.y);
        // No point has a ray: beyond the circle or disc, unless a sliver of the disc's rim
        // (whose Jacobian is singular) cuts the cell between them.
        let area = (p11.x - p00.x) * (p11.y - p00.y);
        if all.iter().all(|p| p.uv.is_none()) && omega() <= 1e-9 * area * self.lens.jacobian(0.0, 0.0) {
            return;
        }
        let uv = self.unwrapped(&all);
        let mut limit = max_depth;
        if let Some(uv) = uv {
            match self.simple(&uv, depth >= max_depth) {
                Some(flat) => {
                    // The octagon around: p00, eb, p10, er, p11, et, p01, el. Weighted by the
                    // lens's exact solid angle where it has one, and by its own measure for a
                    // flat fisheye cell (better than the midpoint rule).
                    let octagon = [uv[0], uv[4], uv[1], uv[6], uv[3], uv[7], uv[2], uv[5]];
                    let exact = self.lens.model != Model::Fisheye || !flat;
                    return self.clip_polygon(octagon, exact.then(omega), acc, weight);
                }
                // Too wide: around a pole, where texels are thin wedges.
                None => limit += POLE_DEPTH,
            }
        } else if self.lens.model == Model::Orthographic {
            limit += POLE_DEPTH;
        } else {
            limit = RIM_DEPTH.min(max_depth);
        }
        if depth < limit {
            for child in [[p00, eb, el, centre], [eb, p10, centre, er], [el, centre, p01, et], [centre, er, et, p11]] {
                self.cell(child, depth + 1, max_depth, acc, weight);
            }
            return;
        }
        let omega = omega();
        if omega > 0.0 {
            let d = self.r * self.lens.ray_clamped(xm, ym);
            let (i, j) = latlong::texel_of_direction(d.into(), self.env.width, self.env.height);
            add(acc, weight, self.env.pixel(i, j), omega);
        }
    }

    /// The nine points' (u, v), u unwrapped to within half a turn of the first; `None` if one
    /// has no ray.
    fn unwrapped(&self, points: &[Point; 9]) -> Option<[[f64; 2]; 9]> {
        let w = self.env.width as f64;
        let mut out = [[0.0; 2]; 9];
        let first = points[0].uv?[0];
        for (o, p) in out.iter_mut().zip(points) {
            let [u, v] = p.uv?;
            *o = [u + w * ((first - u) / w).round(), v];
        }
        Some(out)
    }

    /// Whether the cell is small and flat enough to be clipped as its octagon, `Some(true)`;
    /// or small and in one texel, or small at the depth limit (`last`), `Some(false)`.
    fn simple(&self, uv: &[[f64; 2]; 9], last: bool) -> Option<bool> {
        let (lo, hi) = uv.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
            ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
        });
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        if span > MAX_SPAN {
            return None;
        }
        // An edge's midpoint off its chord by `dev` puts the octagon's half-edges about dev / 4
        // off the curve (the deviation of a smooth arc grows with its length squared).
        let mid = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        let off = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).abs().max((p[1] - q[1]).abs());
        let tests = [
            (uv[4], mid(uv[0], uv[1])),
            (uv[5], mid(uv[0], uv[2])),
            (uv[6], mid(uv[1], uv[3])),
            (uv[7], mid(uv[2], uv[3])),
        ];
        let flat = tests.iter().all(|&(p, q)| 0.25 * off(p, q) <= FLATNESS * span);
        let one_texel = lo[0].floor() == hi[0].floor() && lo[1].floor() == hi[1].floor();
        (flat || one_texel || last).then_some(flat)
    }

    /// The channels of texel (i, j), i wrapped, j clamped.
    fn texel(&self, i: isize, j: isize) -> &[f32] {
        let (w, h) = (self.env.width as isize, self.env.height as isize);
        self.env.pixel(i.rem_euclid(w) as usize, j.clamp(0, h - 1) as usize)
    }

    /// Adds the texels the octagon overlaps, each piece weighted by its solid angle
    /// `(2 pi / W)(pi / H) area sin(theta)`; or, given the cell's solid angle `omega` (a cell
    /// that is not flat, whose octagon's area is not to be trusted), that shared among the
    /// pieces in proportion to those weights.
    fn clip_polygon(&self, octagon: [[f64; 2]; 8], omega: Option<f64>, acc: &mut [f64], weight: &mut f64) {
        let h = self.env.height as f64;
        // At most 3 x 3 texels (the span is at most 2).
        let mut pieces = [(0isize, 0isize, 0.0f64); 9];
        let (mut n, mut total) = (0, 0.0);
        let (lo, hi) = octagon.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
            ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
        });
        let (j0, j1) = (lo[1].floor().max(0.0) as isize, hi[1].floor().min(h - 1.0) as isize);
        for j in j0..=j1 {
            for i in lo[0].floor() as isize..=hi[0].floor() as isize {
                let mut poly = Polygon::from(octagon);
                for (axis, bound, keep_above) in
                    [(0, i as f64, true), (0, (i + 1) as f64, false), (1, j as f64, true), (1, (j + 1) as f64, false)]
                {
                    poly = poly.clip(axis, bound, keep_above);
                }
                if let Some((area, v)) = poly.area_and_centroid_v() {
                    if n < pieces.len() {
                        let piece = area * (PI * v / h).sin();
                        pieces[n] = (i, j, piece);
                        n += 1;
                        total += piece;
                    }
                }
            }
        }
        if total > 0.0 {
            let scale = omega.map_or((2.0 * PI / self.env.width as f64) * (PI / h), |o| o / total);
            for &(i, j, piece) in &pieces[..n] {
                add(acc, weight, self.texel(i, j), scale * piece);
            }
        }
    }
}

fn add(acc: &mut [f64], weight: &mut f64, value: &[f32], omega: f64) {
    for (a, &v) in acc.iter_mut().zip(value) {
        *a += omega * v as f64;
    }
    *weight += omega;
}

/// A polygon of at most 16 vertices (an octagon clipped by four half-planes: each clip adds at
/// most one vertex to a convex polygon, and a nearly convex octagon stays within 16).
struct Polygon {
    p: [[f64; 2]; 16],
    n: usize,
}

impl Polygon {
    fn from(octagon: [[f64; 2]; 8]) -> Polygon {
        let mut p = [[0.0; 2]; 16];
        p[..8].copy_from_slice(&octagon);
        Polygon { p, n: 8 }
    }

    /// The part with `p[axis] >= bound` (`keep_above`) or `<= bound`.
    fn clip(&self, axis: usize, bound: f64, keep_above: bool) -> Polygon {
        let inside = |q: [f64; 2]| if keep_above { q[axis] >= bound } else { q[axis] <= bound };
        let mut out = Polygon { p: [[0.0; 2]; 16], n: 0 };
        let mut push = |q: [f64; 2]| {
            if out.n < 16 {
                out.p[out.n] = q;
                out.n += 1;
            }
        };
        for k in 0..self.n {
            let (a, b) = (self.p[(k + self.n - 1) % self.n], self.p[k]);
            let crossing = || {
                let t = (bound - a[axis]) / (b[axis] - a[axis]);
                [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
            };
            match (inside(a), inside(b)) {
                (true, true) => push(b),
                (false, true) => {
                    push(crossing());
                    push(b)
                }
                (true, false) => push(crossing()),
                (false, false) => {}
            }
        }
        out
    }

    /// |area| and the centroid's v (shoelace), `None` when empty.
    fn area_and_centroid_v(&self) -> Option<(f64, f64)> {
        let (mut twice_area, mut moment) = (0.0, 0.0);
        for k in 0..self.n {
            let (a, b) = (self.p[k], self.p[(k + 1) % self.n]);
            let cross = a[0] * b[1] - b[0] * a[1];
            twice_area += cross;
            moment += (a[1] + b[1]) * cross;
        }
        (self.n >= 3 && twice_area.abs() > 1e-300).then(|| (0.5 * twice_area.abs(), moment / (3.0 * twice_area)))
    }
}

/// The `Area` view of `env` (any channels) through `lens` rotated by `r` (world rays `r c`);
/// channel names kept.
pub fn project_area(env: &Image, lens: &Lens, r: DMat3) -> Image {
    let (w, h, c) = (lens.width, lens.height, env.channels);
    let view = View { env, lens, r };
    // Pixel corners: grid point (i, j) at continuous pixel position (i, j).
    let corners: Vec<Point> = (0..(w + 1) * (h + 1))
        .into_par_iter()
        .map(|k| {
            let (x, y) = lens.plane((k % (w + 1)) as f64, (k / (w + 1)) as f64);
            view.point(x, y)
        })
        .collect();
    let texel_angle = (PI / env.height as f64).min(2.0 * PI / env.width as f64);
    let mut out = Image::with_names(w, h, env.names.clone(), vec![0.0; w * h * c]);
    out.data.par_chunks_mut(w * c).enumerate().for_each(|(j, row)| {
        let mut acc = vec![0.0; c];
        for i in 0..w {
            let at = |i: usize, j: usize| corners[j * (w + 1) + i];
            // (x0, y0) is the bottom-left corner: pixel position (i, j + 1).
            let cell = [at(i, j + 1), at(i + 1, j + 1), at(i, j), at(i + 1, j)];
            let angle = lens.rect_angle(cell[0].x, cell[3].x, cell[0].y, cell[3].y);
            let forced = (angle / texel_angle).log2().ceil().max(0.0) as i32;
            acc.fill(0.0);
            let mut weight = 0.0;
            view.cell(cell, 0, forced + EXTRA_DEPTH, &mut acc, &mut weight);
            if weight > 0.0 {
                for (o, a) in row[i * c..(i + 1) * c].iter_mut().zip(&acc) {
                    *o = (a / weight) as f32;
                }
            }
        }
    });
    out
}

#[cfg(test)]
mod tests;
