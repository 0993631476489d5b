//! Camera lenses: how a pixel of a `W x H` view maps to a ray, in camera space, for the
//! perspective, equidistant fisheye and orthographic models, and back.
//!
//! **Camera space** is hdrflow's world frame before the view's rotation: the camera looks down
//! -Z (the centre column of a lat-long map), +X is right, +Y up. A view rotated by `R`
//! (`Rotation::from_yaw_pitch_roll`, the angles of `Rotate`) sees along `R c` for the camera
//! ray `c`; so yaw 90 looks at -X.
//!
//! **The image plane.** Continuous pixel position `(px, py)`, pixel (i, j) covering
//! `[i, i + 1] x [j, j + 1]` (centre `(i + 0.5, j + 0.5)`), maps to normalised coordinates
//! `u = px / W * 2 - 1`, `v = 1 - py / H * 2`, both in [-1, 1], and to the plane point
//! `(x, y) = (u, v H / W)`: pixels are square, the frame spans `x` in [-1, 1] and
//! `y` in [-H/W, H/W]. `fov` is always the horizontal field of view, in degrees, and `h = fov/2`.
//!
//! | model | ray of plane point (x, y), `r = sqrt(x^2 + y^2)` | has a ray | fov |
//! |---|---|---|---|
//! | `Perspective` | `normalise(x tan h, y tan h, -1)` | everywhere | (0, 180) |
//! | `Fisheye` (equidistant) | angle `theta = r h` from -Z, azimuth `atan2(y, x)` | `r <= 1` (the lens circle) | (0, 360] |
//! | `Orthographic` | `(a, b, -sqrt(1 - a^2 - b^2))`, `(a, b) = (x, y) sin h` | `a^2 + b^2 <= 1` | (0, 180] |
//!
//! So the left and right edges of the frame (x = -1, 1, y = 0) look `h` away from the axis in
//! every model. The orthographic view is the front hemisphere seen from infinitely far: at 180
//! degrees its disc `r <= 1` holds the whole hemisphere, at less the frame is a window of it.
//!
//! **Solid angles** (for footprint means): `dOmega = J dx dy` with
//! `J = tan^2 h / (1 + (x^2 + y^2) tan^2 h)^(3/2)` (perspective), `J = h sin(r h) / r` (fisheye,
//! `h^2` at r = 0) and `J = sin^2 h / sqrt(1 - a^2 - b^2)` (orthographic), 0 where there is no
//! ray. A plane rectangle's solid angle is exact for the perspective (the cube-face formula
//! `geometry::cubemap::rect_solid_angle`, scaled by `tan h`) and the orthographic lens, where
//! in `(a, b)` the antiderivative of `1[a^2 + b^2 <= 1] / sqrt(1 - a^2 - b^2)` over `[0, a] x
//! [0, b]` is, for `a, b >= 0` (odd in each),
//!
//! ```text
//! F(a, b) = b asin(a / sqrt(1 - b^2)) + a asin(b / sqrt(1 - a^2)) - atan(ab / sqrt(1 - a^2 - b^2))   inside the disc,
//! F(a, b) = (pi / 2) (min(a, 1) + min(b, 1) - 1)                                                       outside it
//! ```
//!
//! (integrating by parts; outside, the strip beyond the circle adds `pi / 2` per unit of `a`;
//! tested against a one-dimensional quadrature to 1e-6). For the fisheye it is the midpoint
//! rule `J(centre) dx dy`, whose relative error is `O(dx^2)` (J is smooth and finite on the
//! circle, `h sin h`) and which is 0 for a rectangle whose centre is beyond the circle.

use std::f64::consts::PI;

use glam::DVec3;

use crate::geometry::cubemap;

crate::choice! {
    /// The projection from the image plane to rays.
    pub enum Model {
        /// A pinhole: straight lines stay straight; fov in (0, 180).
        Perspective,
        /// Equidistant fisheye `r = theta / (fov / 2)`, black outside its circle; fov in (0, 360].
        Fisheye,
        /// The hemisphere projected along the axis, `sin(fov / 2)` the frame's half-width; fov in (0, 180].
        Orthographic,
    }
}

/// A lens of one model and horizontal field of view, for a `width` x `height` view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub model: Model,
    pub width: usize,
    pub height: usize,
    /// Half the horizontal field of view, radians.
    pub half: f64,
    /// The plane's scale: `tan h` (perspective), `h` (fisheye), `sin h` (orthographic).
    scale: f64,
}

/// Why `fov` (degrees) does not suit `model`, or `None` when it does: one sentence with the
/// model's range, the value given and, for a view too wide for its model, the model that has it.
pub fn fov_problem(model: Model, fov: f64) -> Option<String> {
    let (ok, range) = match model {
        Model::Perspective => (fov > 0.0 && fov < 180.0, "(0, 180)"),
        Model::Fisheye => (fov > 0.0 && fov <= 360.0, "(0, 360]"),
        Model::Orthographic => (fov > 0.0 && fov <= 180.0, "(0, 180]"),
    };
    if ok {
        return None;
    }
    let article = if model == Model::Orthographic { "an" } else { "a" };
    let wider = match model {
        // A plane holds less than a hemisphere; a disc projected along the axis one hemisphere.
        Model::Perspective if fov >= 180.0 => "; use model: Fisheye for views of 180 degrees or more",
        Model::Orthographic if fov > 180.0 => "; use model: Fisheye for views wider than a hemisphere",
        _ => "",
    };
    Some(format!("{article} {model} view's fov must be in {range} degrees (got {fov}){wider}"))
}

impl Lens {
    /// The lens of `model` with horizontal field of view `fov` degrees; an error names the range.
    pub fn new(model: Model, fov: f64, width: usize, height: usize) -> Result<Lens, String> {
        if let Some(problem) = fov_problem(model, fov) {
            return Err(problem);
        }
        let half = 0.5 * fov.to_radians();
        let scale = match model {
            Model::Perspective => half.tan(),
            Model::Fisheye => half,
            Model::Orthographic => half.sin(),
        };
        Ok(Lens { model, width, height, half, scale })
    }

    /// The frame's half-height on the plane, `H / W` (its half-width is 1).
    pub fn half_height(&self) -> f64 {
        self.height as f64 / self.width as f64
    }

    /// The plane point of continuous pixel position `(px, py)`.
    pub fn plane(&self, px: f64, py: f64) -> (f64, f64) {
        let u = px / self.width as f64 * 2.0 - 1.0;
        let v = 1.0 - py / self.height as f64 * 2.0;
        (u, v * self.half_height())
    }

    /// The continuous pixel position of plane point `(x, y)` (the inverse of [`Lens::plane`]).
    pub fn pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let v = y / self.half_height();
        ((x + 1.0) * 0.5 * self.width as f64, (1.0 - v) * 0.5 * self.height as f64)
    }

    /// Whether `(x, y)` lies in the frame `[-1, 1] x [-H/W, H/W]`.
    pub fn in_frame(&self, x: f64, y: f64) -> bool {
        x.abs() <= 1.0 && y.abs() <= self.half_height()
    }

    /// Whether plane point `(x, y)` has a ray (see the module documentation).
    pub fn has_ray(&self, x: f64, y: f64) -> bool {
        let r2 = x * x + y * y;
        match self.model {
            Model::Perspective => true,
            Model::Fisheye => r2 <= 1.0,
            Model::Orthographic => r2 * self.scale * self.scale <= 1.0,
        }
    }

    /// The unit camera-space ray of plane point `(x, y)`, `None` where there is none.
    pub fn ray(&self, x: f64, y: f64) -> Option<DVec3> {
        self.has_ray(x, y).then(|| self.ray_clamped(x, y))
    }

    /// The ray of `(x, y)`, or where there is none, the ray of the nearest point on the edge of
    /// the region that has rays (the fisheye circle, the orthographic disc): a direction to
    /// look up for a footprint cell that straddles that edge, whose weight decides.
    pub fn ray_clamped(&self, x: f64, y: f64) -> DVec3 {
        let s = self.scale;
        match self.model {
            Model::Perspective => DVec3::new(x * s, y * s, -1.0).normalize(),
            Model::Fisheye => {
                let r = (x * x + y * y).sqrt();
                if r == 0.0 {
                    return DVec3::NEG_Z;
                }
                let (st, ct) = (r.min(1.0) * s).sin_cos();
                DVec3::new(st * x / r, st * y / r, -ct)
            }
            Model::Orthographic => {
                let (a, b) = (x * s, y * s);
                let q = a * a + b * b;
                if q > 1.0 {
                    let n = q.sqrt();
                    return DVec3::new(a / n, b / n, 0.0);
                }
                DVec3::new(a, b, -(1.0 - q).sqrt())
            }
        }
    }

    /// The plane point that sees camera-space direction `c` (any length but 0), `None` when
    /// the model has no point for it (behind a perspective or orthographic camera, beyond the
    /// fisheye's circle). The point may lie outside the frame ([`Lens::in_frame`]).
    pub fn plane_of(&self, c: DVec3) -> Option<(f64, f64)> {
        let c = c.try_normalize()?;
        let s = self.scale;
        match self.model {
            Model::Perspective => (c.z < 0.0).then(|| (c.x / (-c.z * s), c.y / (-c.z * s))),
            Model::Fisheye => {
                let r = (-c.z).clamp(-1.0, 1.0).acos() / s;
                if r > 1.0 {
                    return None;
                }
                let rho = (c.x * c.x + c.y * c.y).sqrt();
                // Straight ahead (r = 0), or straight behind on a 360-degree lens (any azimuth).
                Some(if rho == 0.0 { (r, 0.0) } else { (r * c.x / rho, r * c.y / rho) })
            }
            Model::Orthographic => (c.z <= 0.0).then(|| (c.x / s, c.y / s)),
        }
    }

    /// `dOmega / (dx dy)` at `(x, y)`: 0 where there is no ray.
    pub fn jacobian(&self, x: f64, y: f64) -> f64 {
        if !self.has_ray(x, y) {
            return 0.0;
        }
        let (s, r2) = (self.scale, x * x + y * y);
        match self.model {
            Model::Perspective => s * s / (1.0 + r2 * s * s).powf(1.5),
            Model::Fisheye => {
                let r = r2.sqrt();
                if r == 0.0 {
                    s * s
                } else {
                    s * (r * s).sin() / r
                }
            }
            Model::Orthographic => s * s / (1.0 - r2 * s * s).max(0.0).sqrt(),
        }
    }

    /// The solid angle seen by the plane rectangle `[x0, x1] x [y0, y1]` (`x0 < x1`, `y0 < y1`);
    /// exact or the midpoint rule, as the module documentation says.
    pub fn rect_solid_angle(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
        let s = self.scale;
        match self.model {
            Model::Perspective => cubemap::rect_solid_angle(x0 * s, x1 * s, y0 * s, y1 * s),
            Model::Orthographic => {
                // Beyond the disc the four terms cancel to rounding, which must not go negative.
                let f = |x: f64, y: f64| orthographic_antiderivative(x * s, y * s);
                (f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)).max(0.0)
            }
            _ => self.jacobian(0.5 * (x0 + x1), 0.5 * (y0 + y1)) * (x1 - x0) * (y1 - y0),
        }
    }

    /// The unit camera ray through the centre of pixel (i, j), `None` where there is none.
    pub fn pixel_ray(&self, i: usize, j: usize) -> Option<DVec3> {
        let (x, y) = self.plane(i as f64 + 0.5, j as f64 + 0.5);
        self.ray(x, y)
    }

    /// Whether the centre of pixel (i, j) has a ray.
    pub fn pixel_has_ray(&self, i: usize, j: usize) -> bool {
        let (x, y) = self.plane(i as f64 + 0.5, j as f64 + 0.5);
        self.has_ray(x, y)
    }

    /// The largest angle between opposite corners of the plane rectangle's (clamped) rays: the
    /// angular size a footprint average must resolve.
    pub fn rect_angle(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
        let d = |x, y| self.ray_clamped(x, y);
        d(x0, y0).angle_between(d(x1, y1)).max(d(x1, y0).angle_between(d(x0, y1)))
    }
}

/// `integral over [0, a] x [0, b] of 1[a^2 + b^2 <= 1] da db / sqrt(1 - a^2 - b^2)`, signed (see
/// the module documentation).
fn orthographic_antiderivative(a: f64, b: f64) -> f64 {
    let sign = a.signum() * b.signum();
    let (a, b) = (a.abs().min(1.0), b.abs().min(1.0));
    let q = 1.0 - a * a - b * b;
    if q <= 0.0 {
        return sign * 0.5 * PI * (a + b - 1.0);
    }
    let asin_ratio = |n: f64, d: f64| (n / d.sqrt()).min(1.0).asin();
    sign * (b * asin_ratio(a, 1.0 - b * b) + a * asin_ratio(b, 1.0 - a * a) - (a * b).atan2(q.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens(model: Model, fov: f64) -> Lens {
        Lens::new(model, fov, 64, 48).unwrap()
    }

    #[test]
    fn the_frame_edges_look_half_the_fov_away_in_every_model() {
        for (model, fov) in [(Model::Perspective, 60.0), (Model::Fisheye, 200.0), (Model::Orthographic, 120.0)] {
            let l = lens(model, fov);
            for (x, y) in [(1.0, 0.0), (-1.0, 0.0)] {
                let angle = l.ray(x, y).unwrap().angle_between(DVec3::NEG_Z).to_degrees();
                assert!((angle - fov / 2.0).abs() < 1e-9, "{model}: {angle}");
            }
            // +X right, +Y up.
            assert!(l.ray(0.5, 0.0).unwrap().x > 0.0 && l.ray(0.0, 0.5).unwrap().y > 0.0);
            assert_eq!(l.ray(0.0, 0.0), Some(DVec3::NEG_Z));
        }
        // The fisheye is equidistant: the angle grows linearly with r.
        let f = lens(Model::Fisheye, 180.0);
        let angle = f.ray(0.3, -0.4).unwrap().angle_between(DVec3::NEG_Z);
        assert!((angle - 0.5 * PI / 2.0).abs() < 1e-12);
        assert!(f.ray(0.8, 0.7).is_none());
        assert!(lens(Model::Orthographic, 180.0).ray(0.8, 0.7).is_none());
        assert!(lens(Model::Orthographic, 90.0).ray(0.8, 0.7).is_some());
    }

    #[test]
    fn pixel_centres_follow_the_stated_formula() {
        let l = lens(Model::Perspective, 90.0);
        let (x, y) = l.plane(0.5, 0.5);
        assert!((x - (0.5 / 64.0 * 2.0 - 1.0)).abs() < 1e-15);
        assert!((y - (1.0 - 0.5 / 48.0 * 2.0) * 48.0 / 64.0).abs() < 1e-15);
        let (px, py) = l.pixel(x, y);
        assert!((px - 0.5).abs() < 1e-12 && (py - 0.5).abs() < 1e-12);
    }

    #[test]
    fn rays_and_plane_points_invert() {
        for (model, fov) in
            [(Model::Perspective, 100.0), (Model::Fisheye, 360.0), (Model::Fisheye, 90.0), (Model::Orthographic, 180.0)]
        {
            let l = lens(model, fov);
            for j in 0..48 {
                for i in 0..64 {
                    let (x, y) = l.plane(i as f64 + 0.5, j as f64 + 0.5);
                    if let Some(c) = l.ray(x, y) {
                        assert!((c.length() - 1.0).abs() < 1e-12);
                        let (bx, by) = l.plane_of(c).unwrap();
                        assert!((bx - x).abs() < 1e-9 && (by - y).abs() < 1e-9, "{model} ({i}, {j})");
                    }
                }
            }
        }
        assert_eq!(lens(Model::Perspective, 90.0).plane_of(DVec3::Z), None);
        assert_eq!(lens(Model::Orthographic, 90.0).plane_of(DVec3::new(0.1, 0.0, 0.5)), None);
        assert_eq!(lens(Model::Fisheye, 180.0).plane_of(DVec3::new(0.1, 0.0, 0.5)), None);
        assert!(lens(Model::Fisheye, 360.0).plane_of(DVec3::Z).is_some());
    }

    #[test]
    fn fovs_are_checked_per_model() {
        for (model, bad, good) in [
            (Model::Perspective, [0.0, 180.0, -5.0], [0.5, 179.9]),
            (Model::Fisheye, [0.0, 360.5, f64::NAN], [10.0, 360.0]),
            (Model::Orthographic, [0.0, 180.01, 400.0], [1.0, 180.0]),
        ] {
            for fov in bad {
                let e = Lens::new(model, fov, 8, 8).unwrap_err();
                assert!(e.contains("fov") && e.contains(model.name()), "{e}");
            }
            for fov in good {
                assert!(Lens::new(model, fov, 8, 8).is_ok());
            }
        }
    }

    #[test]
    fn a_fov_too_wide_is_one_sentence_naming_the_model_that_has_it() {
        assert_eq!(
            fov_problem(Model::Perspective, 200.0).unwrap(),
            "a Perspective view's fov must be in (0, 180) degrees (got 200); \
             use model: Fisheye for views of 180 degrees or more"
        );
        assert_eq!(
            fov_problem(Model::Perspective, 180.0).unwrap(),
            "a Perspective view's fov must be in (0, 180) degrees (got 180); \
             use model: Fisheye for views of 180 degrees or more"
        );
        assert_eq!(
            fov_problem(Model::Orthographic, 200.0).unwrap(),
            "an Orthographic view's fov must be in (0, 180] degrees (got 200); \
             use model: Fisheye for views wider than a hemisphere"
        );
        assert_eq!(
            fov_problem(Model::Fisheye, 400.0).unwrap(),
            "a Fisheye view's fov must be in (0, 360] degrees (got 400)"
        );
        assert_eq!(
            fov_problem(Model::Perspective, 0.0).unwrap(),
            "a Perspective view's fov must be in (0, 180) degrees (got 0)"
        );
        assert_eq!(fov_problem(Model::Fisheye, 360.0), None);
    }

    /// Midpoint sum of the Jacobian over a rectangle, n x n cells.
    fn midpoint(l: &Lens, [x0, x1, y0, y1]: [f64; 4], n: usize) -> f64 {
        let (dx, dy) = ((x1 - x0) / n as f64, (y1 - y0) / n as f64);
        (0..n * n)
            .map(|k| l.jacobian(x0 + dx * ((k % n) as f64 + 0.5), y0 + dy * ((k / n) as f64 + 0.5)) * dx * dy)
            .sum()
    }

    /// The orthographic solid angle of `[x0, x1] x [y0, y1]` by a one-dimensional midpoint
    /// quadrature in `a = x sin h`, the inner integral in `b` done exactly (`asin`), clipped to
    /// the disc.
    fn orthographic_reference(l: &Lens, [x0, x1, y0, y1]: [f64; 4], n: usize) -> f64 {
        let s = l.half.sin();
        // Beyond |a| = 1 the integrand is 0: stop there (the inner integral jumps from pi to 0).
        let (a0, a1, b0, b1) = ((x0 * s).max(-1.0), (x1 * s).min(1.0), y0 * s, y1 * s);
        let da = (a1 - a0) / n as f64;
        let inner = |a: f64| {
            let c = (1.0 - a * a).max(0.0).sqrt();
            let (lo, hi) = (b0.max(-c), b1.min(c));
            if hi > lo && c > 0.0 {
                (hi / c).clamp(-1.0, 1.0).asin() - (lo / c).clamp(-1.0, 1.0).asin()
            } else {
                0.0
            }
        };
        (0..n).map(|k| inner(a0 + da * (k as f64 + 0.5)) * da).sum()
    }

    #[test]
    fn solid_angles_agree_with_the_jacobian_and_cover_the_sphere() {
        let inside = [[0.1, 0.3, -0.2, 0.4], [-0.9, -0.7, 0.3, 0.4], [-0.05, 0.05, -0.05, 0.05]];
        let l = lens(Model::Perspective, 120.0);
        for r in inside {
            let (exact, sum) = (l.rect_solid_angle(r[0], r[1], r[2], r[3]), midpoint(&l, r, 400));
            assert!((exact - sum).abs() < 1e-6 * exact, "{r:?}: {exact} vs {sum}");
        }
        // The fisheye's midpoint rule, on cells of a 200-pixel-wide view's pixel size.
        let l = lens(Model::Fisheye, 250.0);
        for r in [[0.1, 0.11, -0.2, -0.19], [-0.9, -0.89, 0.3, 0.31], [-0.005, 0.005, -0.005, 0.005]] {
            let (rule, sum) = (l.rect_solid_angle(r[0], r[1], r[2], r[3]), midpoint(&l, r, 400));
            assert!((rule - sum).abs() < 1e-4 * sum, "{r:?}: {rule} vs {sum}");
        }
        // The orthographic form is exact inside the disc, across its rim and beyond it.
        let l = lens(Model::Orthographic, 170.0);
        for r in inside.into_iter().chain([[-0.9, -0.7, 0.5, 0.7], [0.5, 1.2, -0.3, 0.9], [-0.2, 0.3, 0.9, 1.1]]) {
            let (exact, reference) =
                (l.rect_solid_angle(r[0], r[1], r[2], r[3]), orthographic_reference(&l, r, 100_000));
            assert!((exact - reference).abs() < 1e-6 * exact, "{r:?}: {exact} vs {reference}");
        }
        // A 360-degree fisheye's circle and a 180-degree orthographic disc: 4 pi and 2 pi.
        let full = Lens::new(Model::Fisheye, 360.0, 64, 64).unwrap();
        let sum = midpoint(&full, [-1.0, 1.0, -1.0, 1.0], 2000);
        assert!((sum - 4.0 * PI).abs() < 1e-3, "{sum}");
        let hemi = Lens::new(Model::Orthographic, 180.0, 64, 64).unwrap();
        assert!((hemi.rect_solid_angle(-1.5, 1.5, -1.5, 1.5) - 2.0 * PI).abs() < 1e-12);
    }
}
