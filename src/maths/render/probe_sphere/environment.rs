//! The world of the protocol's scene: an equirectangular map read as Cycles' Environment Texture
//! node reads it.
//!
//! **Orientation.** The scripts feed the node the world's `Generated` coordinate, which for the
//! background is the ray direction, so the node's own mapping applies (`kernel/svm/image.h`,
//! `kernel/camera/projection.h` `direction_to_equirectangular`): for a Blender direction
//! `(x, y, z)` (Z up), `u = 0.5 - atan2(y, x) / (2 pi)` and `v = 1 - acos(z) / pi`, `v = 1` the
//! image's top row. The map's centre column faces +X. In hdrflow's lat-long convention
//! (`geometry::latlong`: Y up, centre column -Z) the same texel is in direction `(-y, z, -x)`
//! ([`to_hdrflow`]); both put `u = x / W` and `theta = pi (row + 0.5) / H` (row 0 at the top) on
//! the same texel centres, so a map needs no resampling.
//!
//! **The lookup** is the node's own: bilinear (`Linear`, the node's default) on texel
//! centres, `x = u W - 0.5`, `y = v H - 0.5`, with the `EXTENSION_REPEAT` wrap of
//! `EnvironmentTextureNode::image_params` in both axes: a lookup within half a row of a pole blends
//! in the row at the other pole, as Cycles' does. The mirror reads it; the rough lobes sum the
//! texels themselves ([`super::texel_tree`]).

use std::f64::consts::PI;

use glam::DVec3;

use crate::maths::resample::angles;
use crate::values::Image;

/// The hdrflow lat-long direction of Blender world direction `d` (the same texel).
#[inline]
pub fn to_hdrflow(d: DVec3) -> DVec3 {
    DVec3::new(-d.y, d.z, -d.x)
}

/// The Blender world direction of hdrflow direction `d` (inverse of [`to_hdrflow`]).
#[inline]
pub fn from_hdrflow(d: DVec3) -> DVec3 {
    DVec3::new(-d.z, -d.x, d.y)
}

/// Where Cycles' Environment Texture reads Blender direction `d` (not zero): `u = 0.5 - atan2(y,
/// x) / (2 pi)` and the polar angle from +Z over pi, both in `[0, 1]`. The angles are
/// [`angles::atan2`]'s (2e-15 rad from libm's; the polar angle as `atan2(sqrt(x^2 + y^2), z)`,
/// which needs no normalisation and no `acos`): the mirror's plan takes one per camera ray.
pub fn coordinates(d: DVec3) -> (f64, f64) {
    let polar = angles::atan2((d.x * d.x + d.y * d.y).sqrt(), d.z);
    (0.5 - angles::atan2(d.y, d.x) / (2.0 * PI), polar / PI)
}

/// An environment map read as Cycles' Environment Texture reads it.
pub struct Environment {
    width: usize,
    height: usize,
    rgb: Vec<[f64; 3]>,
}

impl Environment {
    /// The map's first three channels (one channel is read as grey).
    pub fn new(map: &Image) -> Environment {
        let (w, h) = (map.width, map.height);
        let rgb = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| map.rgb(x, y).map(f64::from)).collect();
        Environment { width: w, height: h, rgb }
    }

    /// Cycles' lookup in Blender direction `d` (need not be unit, must not be zero): bilinear on
    /// texel centres, `x = u W - 0.5` and `y = (1 - v) H - 0.5` from the top, both wrapping.
    pub fn cycles(&self, d: DVec3) -> [f64; 3] {
        let (u, t) = coordinates(d);
        self.at(u, t)
    }

    /// The bilinear lookup at `u` (along the width) and `t` (the polar angle over pi, from the
    /// top), [`coordinates`] of a direction.
    pub fn at(&self, u: f64, t: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (i, wgt) in taps(self.width, self.height, u, t) {
            let p = self.rgb[i];
            for c in 0..3 {
                out[c] += wgt * p[c];
            }
        }
        out
    }

    /// The map's size, width then height.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Texel `i` (row-major, row 0 at the top).
    pub fn texel(&self, i: usize) -> [f64; 3] {
        self.rgb[i]
    }
}

/// The four texels (row-major index, row 0 at the top) and bilinear weights of [`Environment::at`]
/// at `u`, `t` on a `width` x `height` map: texel centres, `x = u W - 0.5`, `y = t H - 0.5`, both
/// wrapping.
pub fn taps(width: usize, height: usize, u: f64, t: f64) -> [(usize, f64); 4] {
    let (fx, fy) = (u * width as f64 - 0.5, t * height as f64 - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (w, h) = (width as isize, height as isize);
    let (x0, y0) = (x0 as isize, y0 as isize);
    // The wrap: an index is at most one period out (u and the polar angle are within [0, 1]),
    // so a comparison does what `rem_euclid`'s division would (kept for anything else).
    let wrap = |i: isize, n: isize| {
        let j = if i < 0 {
            i + n
        } else if i >= n {
            i - n
        } else {
            i
        };
        if (0..n).contains(&j) {
            j as usize
        } else {
            i.rem_euclid(n) as usize
        }
    };
    let (xs, ys) = ([wrap(x0, w), wrap(x0 + 1, w)], [wrap(y0, h), wrap(y0 + 1, h)]);
    [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)]
        .map(|(dx, dy, wgt)| (ys[dy] * width + xs[dx], wgt))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;

    fn ramp(w: usize, h: usize) -> Image {
        Image::from_fn_rgb(w, h, |x, y| [x as f32, y as f32, (x * 7 + y * 3) as f32])
    }

    #[test]
    fn blenders_axes_land_on_the_texels_the_docs_name() {
        let (w, h) = (64, 32);
        let env = Environment::new(&ramp(w, h));
        // At a texel centre the bilinear lookup is the texel; +X is the centre column, +Y a
        // quarter of the width, -Y three quarters, on the equator (between rows 15 and 16).
        let at = |d: DVec3| env.cycles(d);
        let eq = |x: f64| [x, 15.5, x * 7.0 + 15.5 * 3.0];
        for (d, col) in [(DVec3::X, 31.5), (DVec3::Y, 15.5), (-DVec3::Y, 47.5)] {
            let got = at(d);
            assert!((0..3).all(|c| (got[c] - eq(col)[c]).abs() < 1e-9), "{d}: {got:?}");
        }
        // hdrflow's texel-centre directions, turned to Blender's, read back their own texel.
        for (x, y) in [(0, 0), (10, 3), (63, 31), (40, 20)] {
            let d = from_hdrflow(DVec3::from(latlong::texel_direction(x, y, w, h)));
            let got = at(d);
            assert!((got[0] - x as f64).abs() < 1e-9 && (got[1] - y as f64).abs() < 1e-9, "{x} {y}: {got:?}");
            assert!((to_hdrflow(d) - DVec3::from(latlong::texel_direction(x, y, w, h))).length() < 1e-15);
        }
    }

    #[test]
    fn near_a_pole_the_lookup_wraps_to_the_other_pole_as_cycles_repeat_does() {
        let env = Environment::new(&ramp(8, 4));
        // Straight up: fy = -0.5, half row 0 (y = 0) and half row 3 (y = 3).
        let got = env.cycles(DVec3::Z);
        assert!((got[1] - 1.5).abs() < 1e-12, "{got:?}");
    }
}
