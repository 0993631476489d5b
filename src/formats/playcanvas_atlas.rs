//! PlayCanvas' environment atlas (`app.scene.envAtlas`): one 512 x 512 RGBP texture
//! (`formats::rgbp`) holding equirectangular reflection levels and the ambient light, as
//! PlayCanvas' own `EnvLighting.generateAtlas` renders it (line numbers: playcanvas/engine at
//! commit 0aaef5e, whose code ships unchanged in npm 2.23.3's build, checked by grep;
//! `src/scene/graphics/env-lighting.js` lines 137-209, `reproject-texture.js` lines 391-514).
//! Every rect is an equirect of `(w - 2) x (h - 2)` texels inside a 1-texel seam:
//!
//! ```text
//! rect (x, y, w, h), y from texture v = 0 (the PNG's top row: PlayCanvas uploads it unflipped)
//! shiny mips k = 0..5 (generateAtlas' first loop, starting at (0, 0, 512, 256), then x += h,
//!   y += h, w /= 2, h /= 2): (0,0,512,256) (256,256,256,128) (384,384,128,64) (448,448,64,32)
//!   (480,480,32,16) (496,496,16,8); one-sample reprojections of the sharp map (box mips)
//! rough levels i = 1..6 (second loop, from (0, 256, 256, 128), y += h, w /= 2, h /= 2):
//!   (0,256,256,128) (0,384,128,64) (0,448,64,32) (0,480,32,16) (0,496,16,8) (0,504,8,4);
//!   GGX of specularPower max(1, 2048 >> 2i) = 512, 128, 32, 8, 2, 1, i.e. perceptual roughness
//!   1 - log2(power) / 11 = 2/11, 4/11, 6/11, 8/11, 10/11, 1 (alpha = its square; samples weighted
//!   by n.l: reproject-texture.js `generateGGXSamples` lines 260-290, reproject.js
//!   `prefilterSamples`)
//! ambient: (128, 384, 64, 32): the Lambert (cosine) mean of the radiance, E / pi
//! ```
//!
//! The shader (`lit/frag/reflectionEnv.js` lines 24-54, `common/frag/envAtlas.js`) maps an
//! equirect `uv` into a rect with `mix(rect.xy + 1/512, rect.xy + rect.zw - 1/512, uv)` (the seam
//! skipped), reads `level = 5 (1 - gloss)` (perceptual roughness `r = 1 - gloss`): levels 1-5
//! are rough rects 1-5 mixed linearly by the fraction; level 0 is the shiny mip the screen-space
//! derivative picks, mixed towards rough level 1. Rough level 6 is only read by the skybox
//! (`skyboxMip`). Ambient: `lit/frag/ambient.js`, the rect above, added to the diffuse light as
//! it is (no pi).
//!
//! Directions: the lookup is `toSphericalUv(d * (-1, 1, 1))` (`common/frag/spherical.js`:
//! `u = atan(x, z) / 2 pi + 0.5`, `v = 1 - (asin(y) / pi + 0.5)`), so world direction `d`
//! (PlayCanvas' world is right-handed, +Y up, as hdrflow's) is at `u = atan2(-d.x, d.z) / 2 pi +
//! 0.5` from the top: +Z at the centre, +X at a quarter. hdrflow's lat-long has -Z at the centre
//! with the same handedness: PlayCanvas' column `c` is hdrflow's `c + W/2` (a half turn). The
//! seams are the equirect continued past its edges (`reproject.js` `getDirectionEquirect` on
//! `uvMod`-stretched coordinates, `uv = (j + 0.5 - 1) / inner`): the left seam repeats the
//! last column, the top seam row 0 half a turn away (beyond the pole), and so on ([`source_texel`]).

use glam::DVec3;
use std::f64::consts::PI;

use crate::values::Image;

/// The atlas' width and height (`generateAtlas`' default size; its shader's `atlasSize`).
pub const SIZE: usize = 512;

/// One rect of the atlas, seam included, in texels; `y` counts from texture v = 0 (the PNG's
/// top row).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x: usize,
    pub y: usize,
    pub w: usize,
    pub h: usize,
}

/// The six shiny mips (k = 0..5), as `generateAtlas`' first loop lays them out.
pub fn shiny_rects() -> Vec<Rect> {
    let mut r = Rect { x: 0, y: 0, w: 512, h: 256 };
    // calcLevels(256) - calcLevels(4) = 9 - 3
    (0..6)
        .map(|_| {
            let out = r;
            r = Rect { x: r.x + r.h, y: r.y + r.h, w: (r.w / 2).max(1), h: (r.h / 2).max(1) };
            out
        })
        .collect()
}

/// The six rough levels (i = 1..6: index i - 1), as `generateAtlas`' second loop lays them out.
pub fn rough_rects() -> Vec<Rect> {
    let mut r = Rect { x: 0, y: 256, w: 256, h: 128 };
    (1..7)
        .map(|_| {
            let out = r;
            r = Rect { x: r.x, y: r.y + r.h, w: (r.w / 2).max(1), h: (r.h / 2).max(1) };
            out
        })
        .collect()
}

/// The ambient rect.
pub const AMBIENT: Rect = Rect { x: 128, y: 384, w: 64, h: 32 };

/// The specularPower of rough level `i` (1..=6): `max(1, 2048 >> (2 i))`.
pub fn specular_power(i: usize) -> u32 {
    (2048u32 >> (2 * i)).max(1)
}

/// The perceptual roughness PlayCanvas filters rough level `i` with: `1 - log2(power) / 11`.
pub fn level_roughness(i: usize) -> f64 {
    1.0 - (specular_power(i) as f64).log2() / 11.0
}

/// The chain an atlas is made from: level 0 the sharp map, then rough levels 1..=6.
pub fn chain_roughness() -> Vec<f64> {
    std::iter::once(0.0).chain((1..7).map(level_roughness)).collect()
}

/// The level PlayCanvas' shader reads for perceptual roughness `r`: `5 r`, clamped.
pub fn shader_level(r: f64) -> f64 {
    5.0 * r.clamp(0.0, 1.0)
}

/// The world direction PlayCanvas stores at texel `(i, j)` of `rect` (seam included): its
/// `getDirectionEquirect` at `uv = ((i, j) + 0.5 - 1) / inner` (from the rect's v = 0 side, up),
/// seen through the lookup's x mirror.
pub fn direction(rect: Rect, i: usize, j: usize) -> DVec3 {
    let (iw, ih) = ((rect.w - 2) as f64, (rect.h - 2) as f64);
    let (u, v) = ((i as f64 - 0.5) / iw, (j as f64 - 0.5) / ih);
    let (a, e) = ((2.0 * u - 1.0) * PI, (1.0 - 2.0 * v) * PI / 2.0);
    let s = DVec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos());
    DVec3::new(-s.x, s.y, s.z)
}

/// The texel `(x, y)` of an hdrflow lat-long of the rect's inner size that texel `(i, j)` of
/// `rect` holds (module doc: the half turn, and the seams continuing the equirect).
pub fn source_texel(rect: Rect, i: usize, j: usize) -> (usize, usize) {
    let (iw, ih) = (rect.w - 2, rect.h - 2);
    let c = (i + iw - 1) % iw; // PlayCanvas' column, the side seams wrapped
    let (c, row) = match j {
        0 => (c + iw / 2, 0),                     // beyond the top pole
        j if j == ih + 1 => (c + iw / 2, ih - 1), // beyond the bottom pole
        j => (c, j - 1),
    };
    ((c + iw / 2) % iw, row)
}

/// Writes `inner`, an hdrflow lat-long of `(w - 2) x (h - 2)` texels, into `rect` of `atlas`
/// (3 channels, [`SIZE`] square), seams included.
pub fn place(atlas: &mut Image, rect: Rect, inner: &Image) {
    assert_eq!((inner.width, inner.height), (rect.w - 2, rect.h - 2), "the rect's inner size");
    for j in 0..rect.h {
        for i in 0..rect.w {
            let (x, y) = source_texel(rect, i, j);
            let p = inner.pixel(x, y);
            atlas.pixel_mut(rect.x + i, rect.y + j)[..3].copy_from_slice(&p[..3]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong::texel_direction;

    /// The rects of env-lighting.js and the shader's `mapShinyUv` / `mapRoughnessUv` /
    /// ambient rect, in texels.
    #[test]
    fn the_rects_are_playcanvas_generate_atlas_rects() {
        let r = |x, y, w, h| Rect { x, y, w, h };
        assert_eq!(
            shiny_rects(),
            [
                r(0, 0, 512, 256),
                r(256, 256, 256, 128),
                r(384, 384, 128, 64),
                r(448, 448, 64, 32),
                r(480, 480, 32, 16),
                r(496, 496, 16, 8)
            ]
        );
        assert_eq!(
            rough_rects(),
            [
                r(0, 256, 256, 128),
                r(0, 384, 128, 64),
                r(0, 448, 64, 32),
                r(0, 480, 32, 16),
                r(0, 496, 16, 8),
                r(0, 504, 8, 4)
            ]
        );
        // The shader's rects: t = 2^-level; shiny (1 - t, 1 - t, t, t / 2), rough (0, 1 - t, t, t / 2).
        for (k, s) in shiny_rects().iter().enumerate() {
            let t = 512.0 / 2f64.powi(k as i32);
            assert_eq!((s.x as f64, s.w as f64, s.h as f64), (512.0 - t, t, t / 2.0), "{k}");
        }
        for (k, s) in rough_rects().iter().enumerate() {
            let t = 512.0 / 2f64.powi(k as i32 + 1);
            assert_eq!((s.x as f64, s.y as f64, s.w as f64, s.h as f64), (0.0, 512.0 - t, t, t / 2.0), "{k}");
        }
        assert_eq!(AMBIENT, r(128, 384, 64, 32));
        let powers: Vec<u32> = (1..7).map(specular_power).collect();
        assert_eq!(powers, [512, 128, 32, 8, 2, 1]);
        let want = [2.0 / 11.0, 4.0 / 11.0, 6.0 / 11.0, 8.0 / 11.0, 10.0 / 11.0, 1.0];
        for (i, w) in want.iter().enumerate() {
            assert!((level_roughness(i + 1) - w).abs() < 1e-12);
        }
        assert_eq!(shader_level(0.25), 1.25);
    }

    /// Every texel of a rect, seams included, copies the hdrflow lat-long texel whose direction
    /// PlayCanvas stores there.
    #[test]
    fn each_atlas_texel_copies_the_texel_of_its_direction() {
        for rect in [Rect { x: 0, y: 0, w: 34, h: 18 }, AMBIENT, Rect { x: 0, y: 504, w: 8, h: 4 }] {
            let (iw, ih) = (rect.w - 2, rect.h - 2);
            for j in 0..rect.h {
                for i in 0..rect.w {
                    let (x, y) = source_texel(rect, i, j);
                    let got = DVec3::from_array(texel_direction(x, y, iw, ih));
                    let want = direction(rect, i, j);
                    assert!(got.distance(want) < 1e-9, "{rect:?} ({i}, {j}): {got} vs {want}");
                }
            }
        }
    }

    /// World +Z is at the centre of PlayCanvas' equirect, +X at a quarter, up at the top.
    #[test]
    fn world_axes_land_where_playcanvas_reads_them() {
        let r = shiny_rects()[0];
        let at = |u: f64, v: f64| {
            direction(r, (1.0 + u * 510.0 - 0.5).round() as usize, (1.0 + v * 254.0 - 0.5).round() as usize)
        };
        assert!(at(0.5, 0.5).distance(DVec3::Z) < 0.01);
        assert!(at(0.25, 0.5).distance(DVec3::X) < 0.01);
        assert!(at(0.75, 0.5).distance(DVec3::NEG_X) < 0.01);
        assert!(at(0.5, 0.0).y > 0.99);
    }
}
