//! The protocol's camera (`stylelight/mirror.py` with `stylelight/utils/{utils,camera}.py` of
//! DiffusionLight-evaluation): its rays as Cycles 3.4 generates them, with the pixel filter and the
//! lens (`kernel/camera/camera.h` `camera_sample_perspective`, `kernel/sample/mapping.h`).
//!
//! Blender world coordinates (Z up). The camera sits at `(0, -16, 2)` and a Track To constraint
//! (`TRACK_NEGATIVE_Z`, `UP_Y`) turns it to the sphere's origin: forward `(0, 16, -2) / sqrt(260)`,
//! right `+X`, up `(0, 2, 16) / sqrt(260)`. The 36 mm sensor is fitted horizontally to an 85 mm lens,
//! so a pixel `(c, r)` of a `W x H` render (row 0 at the top, as the EXR is stored) at offset
//! `(ox, oy)` from its centre looks along the camera-space direction
//! `(k (2 (c + 0.5 + ox) / W - 1), k (1 - 2 (r + 0.5 + oy) / H) H / W, 1)`, `k = 18 / 85`.
//!
//! - **Pixel filter**: Blender's default, Blackman-Harris of width `w` = 1.5 px. Cycles samples it
//!   separably from a table (`scene/film.cpp` `filter_table`, which doubles the width for this
//!   filter): offsets `|o| <= w` with density `0.35875 - 0.48829 cos t + 0.14128 cos 2t - 0.01168
//!   cos 3t`, `t = 2 pi (o / (2 w) + 1/2)`. [`FilterTable`] inverts the same density's CDF.
//! - **Depth of field** (f/0.5, 11 blades, focus on the sphere): Blender's aperture radius
//!   `lens * 1e-3 / (2 fstop)` = 0.085 units and focus distance, the depth of the sphere's origin
//!   along the view axis, `sqrt(260)`. A lens point `p` uniform over the regular 11-gon of that
//!   circumradius (`regular_polygon_sample`, rotation 0) sends the ray from `p` through the pinhole
//!   ray's point at the focus depth.

use std::f64::consts::PI;

use glam::DVec3;

/// The camera's position (Blender world).
pub const POSITION: DVec3 = DVec3::new(0.0, -16.0, 2.0);
/// Lens focal length and sensor width, millimetres.
pub const LENS_MM: f64 = 85.0;
pub const SENSOR_MM: f64 = 36.0;
/// The f-number and blade count of the protocol's depth of field.
pub const FSTOP: f64 = 0.5;
pub const BLADES: usize = 11;
/// Blender's default pixel filter width, pixels.
pub const FILTER_WIDTH: f64 = 1.5;

/// A ray in Blender world coordinates (unit direction).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
}

/// The protocol's camera at a render size.
#[derive(Clone, Debug)]
pub struct Camera {
    pub width: usize,
    pub height: usize,
    right: DVec3,
    up: DVec3,
    forward: DVec3,
    /// half the sensor width over the focal length
    k: f64,
    aperture: f64,
    focus: f64,
}

impl Camera {
    pub fn new(width: usize, height: usize) -> Camera {
        let forward = (-POSITION).normalize();
        // Track To with up axis Y: the camera's Y is world Z made orthogonal to the view.
        let up = (DVec3::Z - DVec3::Z.dot(forward) * forward).normalize();
        let right = forward.cross(up);
        Camera {
            width,
            height,
            right,
            up,
            forward,
            k: 0.5 * SENSOR_MM / LENS_MM,
            aperture: LENS_MM * 1e-3 / (2.0 * FSTOP),
            focus: forward.dot(-POSITION).abs(),
        }
    }

    /// The focal length in pixels, `W lens / sensor`.
    pub fn focal_px(&self) -> f64 {
        self.width as f64 / (2.0 * self.k)
    }

    /// The pinhole ray of pixel `(c, r)` at offset `(ox, oy)` from its centre, in pixels.
    pub fn pinhole(&self, c: f64, r: f64, ox: f64, oy: f64) -> Ray {
        let d = self.camera_dir(c, r, ox, oy);
        Ray { origin: POSITION, dir: self.to_world(d).normalize() }
    }

    /// The ray of pixel `(c, r)` at filter offset `(ox, oy)` through lens point `lens` (in the unit
    /// square, mapped onto the 11-gon as Cycles maps it).
    pub fn ray(&self, c: f64, r: f64, ox: f64, oy: f64, lens: [f64; 2]) -> Ray {
        self.ray_through(c, r, ox, oy, lens_point(lens))
    }

    /// [`Camera::ray`] through a point `[x, y]` of the aperture polygon of circumradius 1.
    pub fn ray_through(&self, c: f64, r: f64, ox: f64, oy: f64, [lx, ly]: [f64; 2]) -> Ray {
        let d = self.camera_dir(c, r, ox, oy);
        let p = DVec3::new(lx * self.aperture, ly * self.aperture, 0.0);
        // The pinhole ray meets the plane of focus at d * focus / d.z (d.z = 1).
        let dir = (d * self.focus - p).normalize();
        Ray { origin: POSITION + self.to_world(p), dir: self.to_world(dir).normalize() }
    }

    fn camera_dir(&self, c: f64, r: f64, ox: f64, oy: f64) -> DVec3 {
        let (w, h) = (self.width as f64, self.height as f64);
        let sx = 2.0 * (c + 0.5 + ox) / w - 1.0;
        let sy = (1.0 - 2.0 * (r + 0.5 + oy) / h) * h / w;
        DVec3::new(self.k * sx, self.k * sy, 1.0)
    }

    fn to_world(&self, d: DVec3) -> DVec3 {
        d.x * self.right + d.y * self.up + d.z * self.forward
    }
}

/// The aperture point (circumradius 1) of unit-square point `lens`, as Cycles maps it for the
/// protocol's 11 blades.
pub fn lens_point(lens: [f64; 2]) -> [f64; 2] {
    regular_polygon_sample(BLADES as f64, 0.0, lens[0], lens[1])
}

/// Cycles' `regular_polygon_sample(corners, rotation, u, v)`: a point uniform over the regular
/// polygon of circumradius 1, from `(u, v)` uniform over the unit square.
pub fn regular_polygon_sample(corners: f64, rotation: f64, u: f64, v: f64) -> [f64; 2] {
    // Sample the corner's triangle and reuse u.
    let corner = (u * corners).floor();
    let u = u * corners - corner;
    // Uniform point in the triangle (0, c1, c2).
    let su = u.sqrt();
    let v = v * su;
    let u = 1.0 - su;
    let angle = PI / corners;
    let p = [(u + v) * angle.cos(), (u - v) * angle.sin()];
    let rot = rotation + corner * 2.0 * angle;
    let (sr, cr) = rot.sin_cos();
    [cr * p[0] - sr * p[1], sr * p[0] + cr * p[1]]
}

/// Blender's Blackman-Harris window over `|x| <= width` (`filter_func_blackman_harris` with the
/// width doubled).
pub fn blackman_harris(x: f64, width: f64) -> f64 {
    let t = 2.0 * PI * (x / (2.0 * width) + 0.5);
    0.35875 - 0.48829 * t.cos() + 0.14128 * (2.0 * t).cos() - 0.01168 * (3.0 * t).cos()
}

/// The inverse CDF of the pixel filter: an offset in pixels for `u` in [0, 1].
#[derive(Clone, Debug)]
pub struct FilterTable {
    /// CDF at `cells + 1` evenly spaced offsets over `[-width, width]`
    cdf: Vec<f64>,
    width: f64,
}

impl FilterTable {
    /// The Blackman-Harris filter of `width` (trapezoid rule on 4096 cells, as fine as needed for
    /// a smooth window).
    pub fn blackman_harris(width: f64) -> FilterTable {
        let cells = 4096;
        let step = 2.0 * width / cells as f64;
        let mut cdf = Vec::with_capacity(cells + 1);
        let mut acc = 0.0;
        cdf.push(0.0);
        for i in 0..cells {
            let (a, b) = (-width + i as f64 * step, -width + (i + 1) as f64 * step);
            acc += 0.5 * (blackman_harris(a, width) + blackman_harris(b, width)) * step;
            cdf.push(acc);
        }
        cdf.iter_mut().for_each(|c| *c /= acc);
        FilterTable { cdf, width }
    }

    /// The offset whose CDF is `u` (linear between the table's points).
    pub fn offset(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        let i = self.cdf.partition_point(|&c| c < u).clamp(1, self.cdf.len() - 1);
        let (c0, c1) = (self.cdf[i - 1], self.cdf[i]);
        let t = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.0 };
        let step = 2.0 * self.width / (self.cdf.len() - 1) as f64;
        -self.width + (i as f64 - 1.0 + t) * step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_camera_frame_is_the_track_to_constraints() {
        let cam = Camera::new(960, 540);
        assert!((cam.right - DVec3::X).length() < 1e-15);
        let s = 260f64.sqrt();
        assert!((cam.up - DVec3::new(0.0, 2.0 / s, 16.0 / s)).length() < 1e-15);
        assert!((cam.focus - s).abs() < 1e-12);
        assert!((cam.aperture - 0.085).abs() < 1e-15);
        assert!((cam.focal_px() - 2_266.666_666_666_667).abs() < 1e-9);
        // The centre of the frame (between the four middle pixels) looks at the origin.
        let ray = cam.pinhole(479.5, 269.5, 0.0, 0.0);
        assert!(ray.dir.cross(-POSITION.normalize()).length() < 1e-15);
        // Every lens point's ray through the frame centre passes the focus point, the origin.
        for lens in [[0.1, 0.9], [0.5, 0.5], [0.97, 0.02]] {
            let ray = cam.ray(479.5, 269.5, 0.0, 0.0, lens);
            let t = -ray.origin.dot(ray.dir);
            assert!((ray.origin + t * ray.dir).length() < 1e-12);
        }
        // Up in the image is up in the world.
        assert!(cam.pinhole(479.5, 0.0, 0.0, 0.0).dir.z > cam.pinhole(479.5, 539.0, 0.0, 0.0).dir.z);
    }

    #[test]
    fn the_polygon_samples_stay_inside_the_eleven_gon() {
        // Inside: below the apothem along each edge's outward normal (angles 2 pi k / 11).
        let apothem = (PI / 11.0).cos();
        let mut farthest: f64 = 0.0;
        for i in 0..400 {
            let (u, v) = ((i as f64 + 0.5) / 400.0, (i * 37 % 400) as f64 / 400.0);
            let [x, y] = regular_polygon_sample(11.0, 0.0, u, v);
            for k in 0..11 {
                let (s, c) = (2.0 * PI * k as f64 / 11.0).sin_cos();
                assert!(x * c + y * s <= apothem + 1e-12, "{u} {v}");
            }
            farthest = farthest.max((x * x + y * y).sqrt());
        }
        assert!(farthest > 0.95 && farthest <= 1.0 + 1e-12, "{farthest}");
    }

    #[test]
    fn the_filter_table_inverts_a_symmetric_window_of_the_stated_spread() {
        let t = FilterTable::blackman_harris(FILTER_WIDTH);
        assert!(t.offset(0.5).abs() < 1e-9);
        assert!((t.offset(0.0) + 1.5).abs() < 1e-9 && (t.offset(1.0) - 1.5).abs() < 1e-9);
        assert!((t.offset(0.2) + t.offset(0.8)).abs() < 1e-9);
        // Standard deviation 0.4155 px (the midpoint rule over u).
        let n = 100_000;
        let var: f64 = (0..n).map(|i| t.offset((i as f64 + 0.5) / n as f64).powi(2)).sum::<f64>() / n as f64;
        assert!((var.sqrt() - 0.4155).abs() < 1e-3, "{}", var.sqrt());
    }
}
