//! The solid angle of the part of a lat-long cell on the inner side of up to four planes through
//! the origin, with a bound on its error: what [`super::latlong_cube`] gathers for a source texel
//! that straddles a cube texel's edges, in place of splitting it into leaves counted by their
//! centres.
//!
//! **The cell** is `theta in [theta0, theta0 + h_theta]`, `phi in [phi0, phi0 + h_phi]`, with
//! local coordinates `(u, v)` in the square `[-1/2, 1/2]^2` (`u` along theta, `v` along phi). A
//! plane's value `f(u, v) = n . d(theta, phi)` is known exactly at the four corners; it is replaced
//! by the plane `L(u, v)` that is the bilinear interpolant of the corners without its twist term,
//! and the square is clipped by every `L_k >= 0` (a convex polygon, [`super::polygon`]).
//!
//! **The solid angle** of the polygon is `int sin(theta) dtheta dphi`: with `x = theta - theta_c`
//! about the cell's centre, `sin(theta_c + x) = sin(theta_c) (1 - x^2 / 2) + cos(theta_c) x + r`,
//! `|r| <= |x|^3 / 5` for `|x| <= 1/2`, integrated exactly over the polygon from its area and first
//! and second moments in `x` ([`Poly::moments_u`]).
//!
//! **The error bound.** `|f - L| <= delta = |twist| / 4 + |n| (h_theta^2 + h_phi^2 sin_max) / 8`: the
//! twist is the bilinear interpolant's departure from `L`, and the second term bounds the bilinear
//! interpolant's own error, `(1/8)(max |f_uu| + max |f_vv|)`, with `|d^2 d / d theta^2| = 1` and
//! `|d^2 d / d phi^2| = sin(theta) <= sin_max` for the unit direction `d(theta, phi)`. So the true
//! and the clipped regions differ only within the bands `|L_k| <= delta_k`, each of area at most `2 sqrt(2) delta_k / |grad L_k|` in the unit
//! square (its width times the square's longest chord), times `h_theta h_phi sin_max` of solid
//! angle. A plane with `L_k >= delta_k` at every corner holds on the whole cell and adds nothing;
//! the bound adds the Taylor remainder `area (h_theta / 2)^3 / 5`. Tested against a fine
//! subdivision on random cells and planes, the true error below the bound.

use super::polygon::{Clipped as Cut, Line, Poly};

/// The polygons: the square clipped by up to four planes.
type Poly8 = Poly<8>;

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
/// its corners `corners[k] = [f(-, -), f(-, +), f(+, -), f(+, +)]` (`(u, v)`) and their normals'
/// lengths `norms[k]` (see the module documentation).
#[inline]
pub fn clip_cell(cell: &CellShape, corners: &[[f64; 4]], norms: &[f64]) -> Clipped {
    let (h_theta, h_phi) = (cell.h_theta, cell.h_phi);
    let curvature = (h_theta * h_theta + h_phi * h_phi * cell.sin_max) / 8.0;
    // Two buffers, clipped from one into the other.
    let mut polygons = [Poly8::SQUARE, Poly8::SQUARE];
    let mut current = 0;
    let mut band = 0.0;
    for (f, norm) in corners.iter().zip(norms) {
        let [f00, f01, f10, f11] = *f;
        let b = 0.5 * ((f10 - f00) + (f11 - f01));
        let c = 0.5 * ((f01 - f00) + (f11 - f10));
        let a = 0.25 * (f00 + f01 + f10 + f11);
        let delta = 0.25 * (f00 - f01 - f10 + f11).abs() + norm * curvature;
        // L's bounds over the square, at its corners.
        let reach = 0.5 * (b.abs() + c.abs());
        if a - reach >= delta {
            continue;
        }
        if a + reach <= -delta {
            return Clipped { omega: 0.0, error: 0.0 };
        }
        let gradient = (b * b + c * c).sqrt();
        band += if gradient > 0.0 { (2.0 * std::f64::consts::SQRT_2 * delta / gradient).min(1.0) } else { 1.0 };
        let (first, second) = polygons.split_at_mut(1);
        let (from, to) = if current == 0 { (&first[0], &mut second[0]) } else { (&second[0], &mut first[0]) };
        match from.cut(Line { a, b, c }, to) {
            Cut::All => continue,
            Cut::Nothing => return Clipped { omega: 0.0, error: band.min(1.0) * h_theta * h_phi * cell.sin_max },
            Cut::Part => current ^= 1,
        }
    }
    let [area, mx, mxx] = polygons[current].moments_u(h_theta, h_phi);
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
            .map(|(u, v)| p.dot(direction(theta0 + u * h_theta, phi0 + v * h_phi)))
    }

    /// The moments of the square's half `u >= 0`: area 1/2, `int u = 1/8`, `int u^2 = 1/24`.
    #[test]
    fn the_moments_of_a_half_square() {
        let half = Poly8::SQUARE.clip(Line { a: 0.0, b: 1.0, c: 0.0 });
        let [area, mu, muu] = half.moments_u(1.0, 1.0);
        assert!((area - 0.5).abs() < 1e-15 && (mu - 0.125).abs() < 1e-15 && (muu - 1.0 / 24.0).abs() < 1e-15);
        let [area, mu, muu] = half.moments_u(2.0, 3.0);
        assert!((area - 3.0).abs() < 1e-14 && (mu - 1.5).abs() < 1e-14 && (muu - 1.0).abs() < 1e-14);
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
