//! The solid angle of the part of a lat-long cell on the inner side of up to four planes through
//! the origin, with a bound on its error: what [`super::latlong_cube`] gathers for a source texel
//! that straddles a cube texel's edges, in place of splitting it into leaves counted by their
//! centres.
//!
//! **The cell** is `theta in [theta0, theta0 + h_theta]`, `phi in [phi0, phi0 + h_phi]`, with
//! local coordinates `(s, t)` in the unit square (`s` along theta, `t` along phi). A plane's value
//! `f(s, t) = n . d(theta, phi)` is known exactly at the four corners; it is replaced by the plane
//! `L(s, t)` that is the bilinear interpolant of the corners without its twist term, and the unit
//! square is clipped by every `L_k >= 0` (a convex polygon, Sutherland-Hodgman).
//!
//! **The solid angle** of the polygon is `int sin(theta) dtheta dphi`: with `x = theta - theta_c`
//! about the cell's centre, `sin(theta_c + x) = sin(theta_c) (1 - x^2 / 2) + cos(theta_c) x + r`,
//! `|r| <= |x|^3 / 5` for `|x| <= 1/2`, integrated exactly over the polygon from its area and first
//! and second moments in `x` (the shoelace formulas).
//!
//! **The error bound.** `|f - L| <= delta = |twist| / 4 + |n| (h_theta^2 + h_phi^2 sin_max) / 8`: the
//! twist is the bilinear interpolant's departure from `L`, and the second term bounds the bilinear
//! interpolant's own error, `(1/8)(max |f_ss| + max |f_tt|)`, with `|d_theta theta| = 1` and
//! `|d_phi phi| = sin(theta) <= sin_max`. So the true and the clipped regions differ only within
//! the bands `|L_k| <= delta_k`, each of area at most `2 sqrt(2) delta_k / |grad L_k|` in the unit
//! square (its width times the square's longest chord), times `h_theta h_phi sin_max` of solid
//! angle. A plane with `L_k >= delta_k` at every corner holds on the whole cell and adds nothing;
//! the bound adds the Taylor remainder `area (h_theta / 2)^3 / 5`. Tested against a fine
//! subdivision on random cells and planes, the true error below the bound.

/// One clipping line `a + b s + c t >= 0` in the unit square.
pub type Line = [f64; 3];

/// A convex polygon in the unit square: up to four lines cut a square into at most 8 vertices.
#[derive(Clone, Copy, Debug)]
pub struct Polygon {
    points: [[f64; 2]; 8],
    len: usize,
}

impl Polygon {
    /// The unit square, counter-clockwise in `(s, t)`.
    pub fn unit_square() -> Polygon {
        let mut points = [[0.0; 2]; 8];
        points[..4].copy_from_slice(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        Polygon { points, len: 4 }
    }

    /// The vertices.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points[..self.len]
    }

    /// The part where `line` is at least 0 (Sutherland-Hodgman against one line: a convex
    /// polygon gains at most one vertex, and the result stays convex).
    pub fn clip(&self, line: Line) -> Polygon {
        let mut out = Polygon { points: [[0.0; 2]; 8], len: 0 };
        self.clip_into(line, &mut out);
        out
    }

    /// [`Polygon::clip`] into `out`.
    #[inline]
    fn clip_into(&self, [a, b, c]: Line, out: &mut Polygon) {
        out.len = 0;
        let value = |p: [f64; 2]| a + b * p[0] + c * p[1];
        let mut push = |p: [f64; 2]| {
            if out.len < out.points.len() {
                out.points[out.len] = p;
                out.len += 1;
            }
        };
        for i in 0..self.len {
            let (p, q) = (self.points[i], self.points[(i + 1) % self.len]);
            let (vp, vq) = (value(p), value(q));
            if vp >= 0.0 {
                push(p);
            }
            if (vp >= 0.0) != (vq >= 0.0) {
                let k = vp / (vp - vq);
                push([p[0] + k * (q[0] - p[0]), p[1] + k * (q[1] - p[1])]);
            }
        }
    }

    /// The area, and the first and second moments in `x`, of the polygon mapped by
    /// `x = (s - 1/2) sx`, `y = (t - 1/2) sy` (shoelace formulas).
    fn moments(&self, sx: f64, sy: f64) -> [f64; 3] {
        let (mut area, mut mx, mut mxx) = (0.0, 0.0, 0.0);
        for i in 0..self.len {
            let (p, q) = (self.points[i], self.points[(i + 1) % self.len]);
            let (x0, y0, x1, y1) = ((p[0] - 0.5) * sx, (p[1] - 0.5) * sy, (q[0] - 0.5) * sx, (q[1] - 0.5) * sy);
            let cross = x0 * y1 - x1 * y0;
            area += cross;
            mx += (x0 + x1) * cross;
            mxx += (x0 * x0 + x0 * x1 + x1 * x1) * cross;
        }
        [area / 2.0, mx / 6.0, mxx / 12.0]
    }
}

/// A lat-long cell: its extents and the sine and cosine of its centre's polar angle, and the
/// largest `sin(theta)` over it.
#[derive(Clone, Copy, Debug)]
pub struct CellShape {
    pub h_theta: f64,
    pub h_phi: f64,
    pub centre: (f64, f64),
    pub sin_max: f64,
}

/// The clipped solid angle and the bound on its error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clipped {
    pub omega: f64,
    pub error: f64,
}

/// The solid angle of the part of `cell` where every plane `k` holds, from the planes' values at
/// its corners `corners[k] = [f(0, 0), f(0, 1), f(1, 0), f(1, 1)]` (`(s, t)`) and their normals'
/// lengths `norms[k]` (see the module documentation).
#[inline]
pub fn clip_cell(cell: &CellShape, corners: &[[f64; 4]], norms: &[f64]) -> Clipped {
    let (h_theta, h_phi) = (cell.h_theta, cell.h_phi);
    let curvature = (h_theta * h_theta + h_phi * h_phi * cell.sin_max) / 8.0;
    // Two buffers, clipped from one into the other.
    let mut polygons = [Polygon::unit_square(), Polygon::unit_square()];
    let mut current = 0;
    let mut band = 0.0;
    for (f, norm) in corners.iter().zip(norms) {
        let [f00, f01, f10, f11] = *f;
        let b = 0.5 * ((f10 - f00) + (f11 - f01));
        let c = 0.5 * ((f01 - f00) + (f11 - f10));
        let a = 0.25 * (f00 + f01 + f10 + f11) - 0.5 * (b + c);
        let delta = 0.25 * (f00 - f01 - f10 + f11).abs() + norm * curvature;
        // L at the corners: the smallest and largest are its bounds over the square.
        let at = [a, a + c, a + b, a + b + c];
        let (lo, hi) = at.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if lo >= delta {
            continue;
        }
        if hi <= -delta {
            return Clipped { omega: 0.0, error: 0.0 };
        }
        let gradient = (b * b + c * c).sqrt();
        band += if gradient > 0.0 { (2.0 * std::f64::consts::SQRT_2 * delta / gradient).min(1.0) } else { 1.0 };
        let (first, second) = polygons.split_at_mut(1);
        if current == 0 {
            first[0].clip_into([a, b, c], &mut second[0]);
        } else {
            second[0].clip_into([a, b, c], &mut first[0]);
        }
        current ^= 1;
    }
    let [area, mx, mxx] = polygons[current].moments(h_theta, h_phi);
    let (sin_c, cos_c) = cell.centre;
    let omega = (sin_c * (area - 0.5 * mxx) + cos_c * mx).max(0.0);
    let half = 0.5 * h_theta;
    let error = band.min(1.0) * h_theta * h_phi * cell.sin_max + area * half * half * half / 5.0;
    Clipped { omega, error }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::sampling::sequences::SplitMix64;
    use glam::DVec3;

    fn direction(theta: f64, phi: f64) -> DVec3 {
        let (st, ct) = theta.sin_cos();
        DVec3::new(-st * phi.sin(), ct, st * phi.cos())
    }

    /// The solid angle of the cell's part inside every plane by an `n x n` midpoint subdivision
    /// of `(theta, phi)`, each cell of its exact solid angle.
    fn subdivided(theta0: f64, phi0: f64, h_theta: f64, h_phi: f64, planes: &[DVec3], n: usize) -> f64 {
        let mut omega = 0.0;
        for i in 0..n {
            let (t0, t1) = (theta0 + h_theta * i as f64 / n as f64, theta0 + h_theta * (i + 1) as f64 / n as f64);
            let w = h_phi / n as f64 * (t0.cos() - t1.cos());
            for j in 0..n {
                let d = direction(0.5 * (t0 + t1), phi0 + h_phi * (j as f64 + 0.5) / n as f64);
                if planes.iter().all(|p| p.dot(d) >= 0.0) {
                    omega += w;
                }
            }
        }
        omega
    }

    fn shape(theta0: f64, h_theta: f64, h_phi: f64) -> CellShape {
        let (t1, tc) = (theta0 + h_theta, theta0 + 0.5 * h_theta);
        let sin_max = if theta0 <= std::f64::consts::FRAC_PI_2 && t1 >= std::f64::consts::FRAC_PI_2 {
            1.0
        } else {
            theta0.sin().max(t1.sin())
        };
        CellShape { h_theta, h_phi, centre: tc.sin_cos(), sin_max }
    }

    fn corners(theta0: f64, phi0: f64, h_theta: f64, h_phi: f64, p: DVec3) -> [f64; 4] {
        [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)]
            .map(|(s, t)| p.dot(direction(theta0 + s * h_theta, phi0 + t * h_phi)))
    }

    #[test]
    fn a_square_clipped_by_a_diagonal_is_half() {
        let p = Polygon::unit_square().clip([1.0, -1.0, -1.0]);
        let [area, _, _] = p.moments(1.0, 1.0);
        assert!((area - 0.5).abs() < 1e-15, "{area}");
        let none = Polygon::unit_square().clip([-1.0, 0.0, 0.0]);
        assert_eq!(none.points().len(), 0);
        let all = Polygon::unit_square().clip([1.0, 0.0, 0.0]);
        assert_eq!(all.points().len(), 4);
    }

    /// A cell with no clipping plane: its exact solid angle `h_phi (cos theta0 - cos theta1)` to
    /// the Taylor remainder, which the bound covers.
    #[test]
    fn an_unclipped_cell_is_its_solid_angle() {
        for (theta0, h) in [(0.001, 0.01), (1.0, 0.02), (3.0, 0.1), (0.5, 0.3)] {
            let cell = shape(theta0, h, 2.0 * h);
            let got = clip_cell(&cell, &[], &[]);
            let exact = 2.0 * h * (theta0.cos() - (theta0 + h).cos());
            assert!((got.omega - exact).abs() <= got.error.max(1e-18), "{theta0} {h}: {got:?} vs {exact}");
        }
    }

    /// On random cells (sizes from a 16384-wide map's texel to a 64-wide one's, near the poles
    /// too) cut by one to four random planes through the origin, the clipped solid angle is
    /// within its bound of a fine subdivision's (whose own error is at most its boundary cells).
    #[test]
    fn the_error_is_within_its_bound() {
        let mut rng = SplitMix64::new(7);
        let mut cut = 0;
        for case in 0..400 {
            let h_theta = std::f64::consts::PI / [8192.0, 2048.0, 256.0, 32.0][case % 4];
            let h_phi = 2.0 * h_theta;
            let theta0 = rng.next_f64() * (std::f64::consts::PI - h_theta);
            let phi0 = rng.next_f64() * 6.0;
            let centre = direction(theta0 + 0.5 * h_theta, phi0 + 0.5 * h_phi);
            let planes: Vec<DVec3> = (0..1 + case % 4)
                .map(|_| {
                    // A plane through the cell: its normal perpendicular to a point of the cell,
                    // scaled as a cube texel's planes are (length 1 to sqrt 2).
                    let at = direction(theta0 + rng.next_f64() * h_theta, phi0 + rng.next_f64() * h_phi);
                    let any = DVec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5);
                    let n = (any - any.dot(at) * at).normalize() * (1.0 + 0.414 * rng.next_f64());
                    if n.dot(centre) < 0.0 && case % 3 == 0 {
                        -n
                    } else {
                        n
                    }
                })
                .collect();
            let values: Vec<[f64; 4]> = planes.iter().map(|&p| corners(theta0, phi0, h_theta, h_phi, p)).collect();
            let norms: Vec<f64> = planes.iter().map(|p| p.length()).collect();
            let got = clip_cell(&shape(theta0, h_theta, h_phi), &values, &norms);
            let n = 400;
            let truth = subdivided(theta0, phi0, h_theta, h_phi, &planes, n);
            // The subdivision's own error: its cells along each plane's trace.
            let cell_omega = h_theta * h_phi * shape(theta0, h_theta, h_phi).sin_max;
            let slack = planes.len() as f64 * 3.0 * cell_omega / n as f64;
            let off = (got.omega - truth).abs();
            assert!(off <= got.error + slack, "case {case}: {} vs {truth}, bound {} + {slack}", got.omega, got.error);
            if got.omega > 0.0 && got.omega < 0.99 * cell_omega {
                cut += 1;
            }
        }
        assert!(cut > 100, "only {cut} cells were cut");
    }
}
