//! The world of the protocol's scene: an equirectangular map read as Cycles' Environment Texture
//! node reads it, plus the filtered lookups the rough lobes' quadrature uses.
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
//! **Level 0** is the node's lookup itself: bilinear (`Linear`, the node's default) on texel
//! centres, `x = u W - 0.5`, `y = v H - 0.5`, with the `EXTENSION_REPEAT` wrap of
//! `EnvironmentTextureNode::image_params` in both axes: a lookup within half a row of a pole blends
//! in the row at the other pole, as Cycles' does.
//!
//! **Coarser levels** (for filtered importance sampling, J. Krivanek and M. Colbert, "Real-time
//! Shading with Filtered Importance Sampling", EGSR 2008): level `k + 1` holds the solid-angle
//! weighted mean of each 2 x 2 block of level `k` (weights `sin theta` of the rows, so a level keeps
//! the map's integral); they are read bilinearly with longitude wrapping and rows held at the poles,
//! and between two levels linearly in the level.

use std::f64::consts::PI;

use glam::DVec3;

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

struct Level {
    width: usize,
    height: usize,
    rgb: Vec<[f64; 3]>,
}

/// An environment map ready for Cycles-exact and filtered lookups.
pub struct Environment {
    levels: Vec<Level>,
}

impl Environment {
    /// The map's first three channels (one channel is read as grey).
    pub fn new(map: &Image) -> Environment {
        let (w, h) = (map.width, map.height);
        let rgb = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| map.rgb(x, y).map(f64::from)).collect();
        let mut levels = vec![Level { width: w, height: h, rgb }];
        while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) {
            let next = downsample(levels.last().unwrap());
            levels.push(next);
        }
        Environment { levels }
    }

    pub fn width(&self) -> usize {
        self.levels[0].width
    }

    pub fn height(&self) -> usize {
        self.levels[0].height
    }

    /// The number of levels (the map and its coarser means down to 1 x 1).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Cycles' lookup in Blender direction `d` (need not be unit, must not be zero).
    pub fn cycles(&self, d: DVec3) -> [f64; 3] {
        let (u, t) = uv(d);
        self.at_level(0, u, t)
    }

    /// The mean radiance around Blender direction `d` over a footprint `lod` levels above the
    /// map's texels (`lod <= 0`: [`Environment::cycles`]).
    pub fn filtered(&self, d: DVec3, lod: f64) -> [f64; 3] {
        let (u, t) = uv(d);
        if !(lod > 0.0) {
            return self.at_level(0, u, t);
        }
        let lod = lod.min((self.levels.len() - 1) as f64);
        let k = lod.floor() as usize;
        let f = lod - k as f64;
        let a = self.at_level(k, u, t);
        if f == 0.0 || k + 1 >= self.levels.len() {
            return a;
        }
        let b = self.at_level(k + 1, u, t);
        [0, 1, 2].map(|c| a[c] + f * (b[c] - a[c]))
    }

    /// Level `k` at texture coordinate `u` and polar fraction `t = acos(z) / pi` (0 at the top).
    fn at_level(&self, k: usize, u: f64, t: f64) -> [f64; 3] {
        let l = &self.levels[k];
        // Rows from the top: (1 - v) H - 0.5 with v = 1 - acos(z) / pi.
        bilinear(l, u * l.width as f64 - 0.5, t * l.height as f64 - 0.5, k == 0)
    }

    /// The solid angle of a map texel at polar angle `theta` (Blender's, from +Z), with the sine
    /// kept at least that of half a row so that footprints stay finite at the poles.
    pub fn texel_solid_angle(&self, theta: f64) -> f64 {
        let (w, h) = (self.width() as f64, self.height() as f64);
        (2.0 * PI / w) * (PI / h) * theta.sin().max((0.5 * PI / h).sin())
    }
}

/// Cycles' `u = 0.5 - atan2(y, x) / (2 pi)` and the polar fraction `acos(z / |d|) / pi` of `d`.
#[inline]
fn uv(d: DVec3) -> (f64, f64) {
    let len = d.length();
    (0.5 - d.y.atan2(d.x) / (2.0 * PI), (d.z / len).clamp(-1.0, 1.0).acos() / PI)
}

/// Bilinear interpolation at `(fx, fy)` (pixel centres at integers, rows from the top), wrapping
/// columns; rows wrap too when `repeat_rows` (Cycles' `EXTENSION_REPEAT`), else are held.
fn bilinear(l: &Level, fx: f64, fy: f64, repeat_rows: bool) -> [f64; 3] {
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (w, h) = (l.width as isize, l.height as isize);
    let col = |x: isize| x.rem_euclid(w) as usize;
    let row = |y: isize| if repeat_rows { y.rem_euclid(h) as usize } else { y.clamp(0, h - 1) as usize };
    let (x0, y0) = (x0 as isize, y0 as isize);
    let mut out = [0.0; 3];
    for (dx, dy, wgt) in [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)] {
        let p = l.rgb[row(y0 + dy) * l.width + col(x0 + dx)];
        for c in 0..3 {
            out[c] += wgt * p[c];
        }
    }
    out
}

/// The next coarser level: solid-angle weighted means of 2 x 2 blocks (the last block of an odd
/// side takes the one remaining texel).
fn downsample(l: &Level) -> Level {
    let (w, h) = ((l.width + 1) / 2, (l.height + 1) / 2);
    let sin_row = |y: usize| (PI * (y as f64 + 0.5) / l.height as f64).sin();
    let mut rgb = vec![[0.0; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let (mut acc, mut wsum) = ([0.0; 3], 0.0);
            for sy in 2 * y..(2 * y + 2).min(l.height) {
                for sx in 2 * x..(2 * x + 2).min(l.width) {
                    let wgt = sin_row(sy);
                    let p = l.rgb[sy * l.width + sx];
                    for c in 0..3 {
                        acc[c] += wgt * p[c];
                    }
                    wsum += wgt;
                }
            }
            rgb[y * w + x] = acc.map(|a| a / wsum);
        }
    }
    Level { width: w, height: h, rgb }
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

    #[test]
    fn coarser_levels_keep_the_solid_angle_mean() {
        let map = ramp(64, 32);
        let env = Environment::new(&map);
        let mean = |k: usize| {
            let l = &env.levels[k];
            let (mut acc, mut wsum) = (0.0, 0.0);
            for y in 0..l.height {
                let s = (PI * (y as f64 + 0.5) / l.height as f64).sin();
                for x in 0..l.width {
                    acc += s * l.rgb[y * l.width + x][2];
                    wsum += s;
                }
            }
            acc / wsum
        };
        assert_eq!(env.level_count(), 7);
        // The exact mean weights by the children's sines; the coarse midpoint sines differ by O(h^2).
        for k in 1..4 {
            assert!((mean(k) - mean(0)).abs() < 2e-2 * mean(0), "{k}: {} {}", mean(k), mean(0));
        }
    }
}
