//! Azimuthal layouts of the sphere in a square image: Debevec's angular probe, the sky-angular
//! hemisphere and the orthographic mirror ball. Each is a disc inscribed in the image around an
//! axis direction; the disc's point (u, v), radius `r = sqrt(u^2 + v^2) <= 1`, looks in the
//! direction at angle alpha(r) from the axis and azimuth atan2(v, u) from the image's right:
//!
//! ```text
//! d = cos(alpha) axis + sin(alpha) (u right + v up) / r
//! ```
//!
//! | layout | axis (centre) | right | up | alpha(r) | dOmega / dA |
//! |---|---|---|---|---|---|
//! | angular (Debevec) | -Z | +X | +Y | pi r | pi sin(pi r) / r |
//! | sky angular | +Y (zenith) | +X | +Z (so -Z is at the bottom) | (pi / 2) r | (pi / 2) sin(pi r / 2) / r |
//! | mirror ball | c, towards the camera | camera right | camera up | 2 asin(r) | 4 |
//!
//! **Mirror ball.** A chrome ball photographed orthographically, cropped to the ball: in the
//! camera's frame (right, up, c = towards the camera) the ball's normal at (u, v) is
//! `n = (u, v, sqrt(1 - u^2 - v^2))` and the camera ray `-c` reflects to `r = 2 (n.c) n - c`
//! (the law of reflection), so `cos(alpha) = 2 n_z^2 - 1 = 1 - 2 r^2`, i.e. `r = sin(alpha / 2)`.
//! The inverse is the half vector: `n = (d + c) / |d + c|`, `(u, v) = (n.right, n.up)`. Then
//! `dOmega = sin(alpha) dalpha dphi = 4 r dr dphi = 4 dA`: the orthographic mirror ball is
//! Lambert's azimuthal equal-area projection, every pixel of an N x N ball image subtends
//! `16 / N^2` sr. The whole rim r = 1 reflects the one direction `-c` behind the ball, where the
//! layout is degenerate (`dalpha / dr = 2 / sqrt(1 - r^2)` grows without bound).
//!
//! **Pixels.** Pixel (x, y) of a W x H image (row 0 at the top) is centred on
//! `u = 2 (x + 0.5) / W - 1`, `v = 1 - 2 (y + 0.5) / H` (v up), as in `geometry::latlong`.
//!
//! The angular and mirror-ball images are views of the sphere from inside it looking along the
//! axis, or, for the ball, the mirror image of the view from the ball towards the camera; the
//! sky-angular disc is the upper hemisphere seen from below looking up, top of the image
//! towards +Z: the view of a camera turned from forward (-Z) up by 90 degrees.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec3;

/// How the disc's radius follows the angle alpha from the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radial {
    /// `r = alpha / max_angle`: equidistant (the angular probe, `max_angle = pi`; the sky-angular
    /// hemisphere, `pi / 2`).
    Equidistant { max_angle: f64 },
    /// `r = sin(alpha / 2)`: the orthographic mirror ball.
    MirrorBall,
}

/// An azimuthal layout: its frame and radial law (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscMap {
    pub right: DVec3,
    pub up: DVec3,
    /// The direction at the disc's centre.
    pub axis: DVec3,
    pub radial: Radial,
}

impl DiscMap {
    /// Debevec's angular probe: forward (-Z) at the centre, +X right, +Y up, alpha = pi r.
    pub const ANGULAR: DiscMap =
        DiscMap { right: DVec3::X, up: DVec3::Y, axis: DVec3::NEG_Z, radial: Radial::Equidistant { max_angle: PI } };

    /// The upper hemisphere seen from below: zenith (+Y) at the centre, +X right, +Z up (-Z at
    /// the bottom), the horizon on the rim, alpha = (pi / 2) r.
    pub const SKY_ANGULAR: DiscMap =
        DiscMap { right: DVec3::X, up: DVec3::Z, axis: DVec3::Y, radial: Radial::Equidistant { max_angle: FRAC_PI_2 } };

    /// A mirror ball photographed by a camera with screen axes `right`, `up` and `towards_camera`
    /// = `right x up` (an orthonormal right-handed frame; the camera looks along
    /// `-towards_camera`).
    pub fn mirror_ball(right: DVec3, up: DVec3, towards_camera: DVec3) -> DiscMap {
        DiscMap { right, up, axis: towards_camera, radial: Radial::MirrorBall }
    }

    /// The disc point (u, v) of the unit direction `d`. A direction at the axis is (0, 0); the
    /// one opposite it is (R, 0), R = pi / max_angle for an equidistant layout (1 for the
    /// angular probe, 2, outside the disc, for the sky's nadir) and 1 for the ball.
    #[inline]
    pub fn uv(&self, d: DVec3) -> (f64, f64) {
        let (x, y, z) = (d.dot(self.right), d.dot(self.up), d.dot(self.axis));
        match self.radial {
            Radial::Equidistant { max_angle } => {
                let s = (x * x + y * y).sqrt();
                if s < 1e-12 {
                    return if z > 0.0 { (0.0, 0.0) } else { (PI / max_angle, 0.0) };
                }
                let r = z.clamp(-1.0, 1.0).acos() / max_angle;
                (x / s * r, y / s * r)
            }
            Radial::MirrorBall => {
                let h = (x * x + y * y + (z + 1.0) * (z + 1.0)).sqrt();
                if h < 1e-12 {
                    return (1.0, 0.0);
                }
                (x / h, y / h)
            }
        }
    }

    /// The unit direction seen at disc point (u, v), or `None` outside the unit disc.
    #[inline]
    pub fn direction(&self, u: f64, v: f64) -> Option<DVec3> {
        (u * u + v * v <= 1.0).then(|| self.direction_clamped(u, v))
    }

    /// The direction at (u, v), a point outside the disc taken on the rim along its radius (the
    /// corners of pixels that straddle the rim).
    #[inline]
    pub fn direction_clamped(&self, u: f64, v: f64) -> DVec3 {
        let r2 = u * u + v * v;
        let (x, y, z) = match self.radial {
            Radial::Equidistant { max_angle } => {
                let r = r2.sqrt();
                if r == 0.0 {
                    return self.axis;
                }
                let (sa, ca) = (max_angle * r.min(1.0)).sin_cos();
                (sa * u / r, sa * v / r, ca)
            }
            Radial::MirrorBall => {
                // n = (u, v, n_z), r = 2 (n.c) n - c with c = (0, 0, 1) in the camera's frame.
                let nz = (1.0 - r2).max(0.0).sqrt();
                if r2 > 1.0 {
                    (0.0, 0.0, -1.0)
                } else {
                    (2.0 * nz * u, 2.0 * nz * v, 2.0 * nz * nz - 1.0)
                }
            }
        };
        self.right * x + self.up * y + self.axis * z
    }

    /// The angle alpha from the axis at disc radius `r` (clamped to [0, 1]).
    #[inline]
    pub fn angle_at_radius(&self, r: f64) -> f64 {
        let r = r.clamp(0.0, 1.0);
        match self.radial {
            Radial::Equidistant { max_angle } => max_angle * r,
            Radial::MirrorBall => 2.0 * r.asin(),
        }
    }

    /// The solid angle per unit disc area at (u, v), `dOmega / (du dv)`.
    #[inline]
    pub fn density(&self, u: f64, v: f64) -> f64 {
        match self.radial {
            Radial::Equidistant { max_angle } => {
                let r = (u * u + v * v).sqrt();
                if r < 1e-12 {
                    max_angle * max_angle
                } else {
                    max_angle * (max_angle * r.min(1.0)).sin() / r
                }
            }
            Radial::MirrorBall => 4.0,
        }
    }

    /// The largest angle (radians) between directions in the pixel of an N x N image centred at
    /// (u, v), bounded by the angles at the radii its bounding circle spans (a pixel's
    /// half-diagonal is sqrt(2) / N in disc units); it sets how finely a footprint is cut.
    pub fn pixel_extent(&self, u: f64, v: f64, n: usize) -> f64 {
        let (c, h) = ((u * u + v * v).sqrt(), std::f64::consts::SQRT_2 / n as f64);
        self.angle_at_radius(c + h) - self.angle_at_radius(c - h)
    }
}

/// Disc coordinates of pixel (x, y)'s centre in a W x H image (v up, row 0 at the top).
#[inline]
pub fn pixel_uv(x: usize, y: usize, width: usize, height: usize) -> (f64, f64) {
    (2.0 * (x as f64 + 0.5) / width as f64 - 1.0, 1.0 - 2.0 * (y as f64 + 0.5) / height as f64)
}

/// Continuous pixel coordinates of disc point (u, v) in a W x H image, pixel centres at integers
/// (the inverse of [`pixel_uv`]).
#[inline]
pub fn uv_pixel(u: f64, v: f64, width: usize, height: usize) -> (f64, f64) {
    ((u + 1.0) * 0.5 * width as f64 - 0.5, (1.0 - v) * 0.5 * height as f64 - 0.5)
}

/// The angular probe's (u, v) of direction `d` (see [`DiscMap::ANGULAR`]).
pub fn angular_uv(d: [f64; 3]) -> (f64, f64) {
    DiscMap::ANGULAR.uv(DVec3::from(d))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball() -> DiscMap {
        DiscMap::mirror_ball(DVec3::X, DVec3::Y, DVec3::Z)
    }

    fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).abs().max_element() < tol
    }

    #[test]
    fn the_axes_land_where_documented() {
        assert_eq!(angular_uv([0.0, 0.0, -1.0]), (0.0, 0.0));
        let (u, v) = angular_uv([1.0, 0.0, 0.0]);
        assert!((u - 0.5).abs() < 1e-12 && v.abs() < 1e-12);
        let (u, v) = angular_uv([0.0, 1.0, 0.0]);
        assert!(u.abs() < 1e-12 && (v - 0.5).abs() < 1e-12);
        assert_eq!(angular_uv([0.0, 0.0, 1.0]), (1.0, 0.0));
        // Sky angular: zenith at the centre, -Z at the bottom, +X on the right, horizon on the rim.
        let sky = DiscMap::SKY_ANGULAR;
        assert_eq!(sky.uv(DVec3::Y), (0.0, 0.0));
        let (u, v) = sky.uv(DVec3::NEG_Z);
        assert!(u.abs() < 1e-12 && (v + 1.0).abs() < 1e-12, "{u} {v}");
        let (u, v) = sky.uv(DVec3::X);
        assert!((u - 1.0).abs() < 1e-12 && v.abs() < 1e-12);
        assert_eq!(sky.uv(DVec3::NEG_Y), (2.0, 0.0));
        // Ball seen looking along -Z: the centre reflects the camera (+Z), the rim the back (-Z),
        // (sin 45 deg, 0) reflects +X (normal at 45 degrees), the top of the disc +Y likewise.
        let b = ball();
        assert!(close(b.direction(0.0, 0.0).unwrap(), DVec3::Z, 1e-15));
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(b.direction(s, 0.0).unwrap(), DVec3::X, 1e-15));
        assert!(close(b.direction(0.0, s).unwrap(), DVec3::Y, 1e-15));
        assert!(close(b.direction(1.0, 0.0).unwrap(), DVec3::NEG_Z, 1e-15));
        assert_eq!(b.uv(DVec3::NEG_Z), (1.0, 0.0));
        assert!(b.direction(0.8, 0.7).is_none());
    }

    #[test]
    fn the_ball_obeys_the_law_of_reflection() {
        // A tilted camera frame: right, up, towards-camera of a rotation.
        let m = glam::DMat3::from_rotation_y(0.4) * glam::DMat3::from_rotation_x(-0.3);
        let (right, up, c) = (m.x_axis, m.y_axis, m.z_axis);
        let b = DiscMap::mirror_ball(right, up, c);
        for &(u, v) in &[(0.1, 0.2), (-0.5, 0.3), (0.6, -0.7), (0.0, -0.99)] {
            let n = right * u + up * v + c * (1.0f64 - u * u - v * v).sqrt();
            let want = n * (2.0 * n.dot(c)) - c;
            let got = b.direction(u, v).unwrap();
            assert!(close(got, want, 1e-14), "{got} vs {want}");
            // Incident and reflected make equal angles with the normal, in one plane.
            assert!((got.dot(n) - c.dot(n)).abs() < 1e-14);
            assert!(got.cross(c).dot(n).abs() < 1e-14);
        }
    }

    #[test]
    fn uv_inverts_direction() {
        let maps = [DiscMap::ANGULAR, DiscMap::SKY_ANGULAR, ball()];
        for m in maps {
            for i in 0..41 {
                for j in 0..41 {
                    let (u, v) = (i as f64 / 20.0 - 1.0, j as f64 / 20.0 - 1.0);
                    if u * u + v * v > 0.995 * 0.995 {
                        continue;
                    }
                    let d = m.direction(u, v).unwrap();
                    assert!((d.length() - 1.0).abs() < 1e-14);
                    let (u2, v2) = m.uv(d);
                    assert!((u2 - u).abs() < 1e-12 && (v2 - v).abs() < 1e-12, "{m:?} ({u}, {v}) -> ({u2}, {v2})");
                }
            }
        }
    }

    #[test]
    fn densities_integrate_to_the_sphere_and_the_hemisphere() {
        // Midpoint sums of dOmega/dA over a 2000 x 2000 grid, cells with centres in the disc:
        // the disc's pixelated edge costs O(1/N) relative at most.
        let n = 2000;
        for (m, want) in [(DiscMap::ANGULAR, 4.0 * PI), (DiscMap::SKY_ANGULAR, 2.0 * PI), (ball(), 4.0 * PI)] {
            let mut sum = 0.0;
            for y in 0..n {
                for x in 0..n {
                    let (u, v) = pixel_uv(x, y, n, n);
                    if u * u + v * v <= 1.0 {
                        sum += m.density(u, v) * (2.0 / n as f64).powi(2);
                    }
                }
            }
            assert!((sum - want).abs() < 1e-3 * want, "{m:?}: {sum} vs {want}");
        }
        // The density is the Jacobian: a small ring's solid angle from the angles at its radii.
        let m = DiscMap::ANGULAR;
        let (r0, r1) = (0.5, 0.501);
        let ring = 2.0 * PI * (m.angle_at_radius(r0).cos() - m.angle_at_radius(r1).cos());
        let area = PI * (r1 * r1 - r0 * r0);
        assert!((ring / area - m.density(0.5005, 0.0)).abs() < 1e-5);
    }

    #[test]
    fn skylibs_layouts_relate_as_documented() {
        // skylibs (envmap/projections.py), image coordinates a, b in [0, 1], b down:
        // sphere: u = 2a - 1, w = 2b - 1, t = atan2(u, -w), p = 2 asin(r):
        //   (sin p sin t, sin p cos t, -cos p), centre -Z, +X right: hdrflow's ball seen by a
        //   camera looking along +Z (right -X, up +Y, c = -Z), mirrored left to right.
        // skyangular: t = atan2(1 - 2b, 2a - 1), p = (pi / 2) r: (sin p cos t, cos p, sin p sin t).
        let ball_plus_z = DiscMap::mirror_ball(DVec3::NEG_X, DVec3::Y, DVec3::NEG_Z);
        for i in 1..20 {
            for j in 1..20 {
                let (a, b) = (i as f64 / 20.0, j as f64 / 20.0);
                let (u, w) = (2.0 * a - 1.0, 2.0 * b - 1.0);
                let r = (u * u + w * w).sqrt();
                if u * u + w * w > 1.0 {
                    continue;
                }
                let (t, p) = (u.atan2(-w), 2.0 * r.asin());
                let sphere = DVec3::new(p.sin() * t.sin(), p.sin() * t.cos(), -p.cos());
                assert!(close(ball_plus_z.direction(-u, -w).unwrap(), sphere, 1e-12), "sphere ({a}, {b})");
                let (t, p) = ((1.0 - 2.0 * b).atan2(2.0 * a - 1.0), PI / 2.0 * r);
                let sky = DVec3::new(p.sin() * t.cos(), p.cos(), p.sin() * t.sin());
                assert!(close(DiscMap::SKY_ANGULAR.direction(u, -w).unwrap(), sky, 1e-12), "skyangular ({a}, {b})");
            }
        }
    }

    #[test]
    fn pixel_centres_invert() {
        let (u, v) = pixel_uv(3, 5, 16, 16);
        assert_eq!(uv_pixel(u, v, 16, 16), (3.0, 5.0));
        assert_eq!(pixel_uv(0, 0, 2, 2), (-0.5, 0.5));
    }
}
