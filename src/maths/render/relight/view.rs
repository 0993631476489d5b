//! [`SphereView`]: the orthographic camera looking at the unit sphere, mapping each pixel of its
//! silhouette to the sphere's normal there. Its own file because the SH, glossy and reference
//! spheres use it as well as the relighting below.

use glam::DVec3;

use crate::geometry::unit;

/// An orthographic camera looking at the unit sphere, whose silhouette is the disc inscribed in a
/// `size` x `size` image.
///
/// Basis: `view_dir` (unit, from the sphere's centre towards the camera), `forward = -view_dir`
/// (the direction the camera looks), screen `up` = +Y projected onto the plane orthogonal to
/// `view_dir` and normalised, `right = forward x up`. This gives the usual right-handed camera: a
/// camera at +Z looking along -Z with up +Y has right = +X. When `view_dir` is (nearly) +Y or -Y,
/// +Y has no usable projection; screen up is then -Z for a camera above (view_dir ~ +Y) and +Z for
/// a camera below (view_dir ~ -Y): the limits reached when the camera rises over (or sinks under)
/// the sphere from the +Z side, so right stays +X.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereView {
    /// Image width and height in pixels.
    pub size: usize,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
}

impl SphereView {
    /// A view of a `size` x `size` image from direction `view_dir` (from the sphere's centre to the
    /// camera; normalised here). A zero or non-finite `view_dir` falls back to +Z.
    pub fn new(size: usize, view_dir: [f64; 3]) -> SphereView {
        let v = unit(DVec3::from(view_dir)).unwrap_or(DVec3::Z);
        let forward = -v;
        // Up: +Y minus its component along v (Gram-Schmidt), written out per component (as
        // `Y - vy v` it would turn some -0 into +0).
        let vy = v.y;
        let projected = DVec3::new(-vy * v.x, 1.0 - vy * v.y, -vy * v.z);
        let up_hint = if projected.length() > 1e-9 {
            unit(projected).unwrap_or(DVec3::Y)
        } else if vy > 0.0 {
            DVec3::NEG_Z
        } else {
            DVec3::Z
        };
        let right = unit(forward.cross(up_hint)).unwrap_or(DVec3::X);
        // Re-orthogonalise so (right, up, view_dir) is orthonormal to rounding.
        let up = unit(right.cross(forward)).unwrap_or(up_hint);
        SphereView { size, forward, right, up }
    }

    /// Unit direction from the sphere's centre towards the camera.
    pub fn view_dir(&self) -> [f64; 3] {
        (-self.forward).to_array()
    }

    /// The direction the camera looks along (`-view_dir`).
    pub fn forward(&self) -> [f64; 3] {
        self.forward.to_array()
    }

    /// Screen right (+x in the image).
    pub fn right(&self) -> [f64; 3] {
        self.right.to_array()
    }

    /// Screen up (towards row 0 of the image).
    pub fn up(&self) -> [f64; 3] {
        self.up.to_array()
    }

    /// The unit surface normal seen at pixel (px, py), or `None` off the silhouette.
    ///
    /// Pixel centre in screen units: `sx = 2 (px + 0.5) / size - 1`, `sy = 1 - 2 (py + 0.5) / size`
    /// (row 0 is the top of the screen). Off the unit disc (`sx^2 + sy^2 > 1`) -> `None`. On it, the
    /// orthographic ray hits the unit sphere at `n = sx right + sy up + sqrt(1 - sx^2 - sy^2) view_dir`
    /// (the visible hemisphere of a unit sphere, where the point equals its normal).
    #[inline]
    pub fn normal_at(&self, px: usize, py: usize) -> Option<[f64; 3]> {
        if self.size == 0 {
            return None;
        }
        let s = self.size as f64;
        let sx = 2.0 * (px as f64 + 0.5) / s - 1.0;
        let sy = 1.0 - 2.0 * (py as f64 + 0.5) / s;
        let r2 = sx * sx + sy * sy;
        if !(r2 <= 1.0) {
            return None;
        }
        let sz = (1.0 - r2).max(0.0).sqrt();
        Some((sx * self.right + sy * self.up + sz * -self.forward).to_array())
    }
}
