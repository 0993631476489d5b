//! RGBD, the 8-bit packing of HDR texels Babylon.js reads from PNG faces: its `.env` files
//! (`formats::babylon_env`) and the `EXT_lights_image_based` images of a glTF asset
//! (`formats::gltf_ibl`; the extension's README: "PNG's - assumed to be HDR images packed in RGBD
//! format"). Babylon's `toRGBD` / `fromRGBD` (`Shaders/ShadersInclude/helperFunctions.fx`):
//! `D = floor(max(255 / max(r, g, b), 1)) / 255`, stored `A = D`, `RGB = (c D)^(1 / 2.2)`;
//! decoded `RGB^2.2 / A`. Values up to 255 fit; a texel brighter than that is clamped (its colour
//! stays, its level drops to 255), and counted ([`chain_pngs`]).
//!
//! Both files go through the same upload (`UploadRadianceLevelsAsync`, `invertY`), so both hold
//! each face of the OpenGL cube bottom row first ([`face_png`]'s `flip_rows`).

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use rayon::prelude::*;

use crate::values::Cubemap;

/// The largest value RGBD holds (`rgbdMaxRange`).
pub const RGBD_MAX: f32 = 255.0;

/// Babylon's gamma for the RGB part (`GammaEncodePowerApprox = 1 / 2.2`).
pub const GAMMA: f32 = 2.2;

/// One linear RGB value as RGBD bytes, and whether it was beyond [`RGBD_MAX`] (then clamped).
/// Negative and non-finite channels count as 0.
pub fn rgbd(c: [f32; 3]) -> ([u8; 4], bool) {
    let c = c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
    let m = c[0].max(c[1]).max(c[2]).max(1e-7);
    let d = (RGBD_MAX / m).max(1.0).floor().min(255.0);
    let scale = d / 255.0;
    let rgb = c.map(|v| ((v * scale).powf(1.0 / GAMMA).clamp(0.0, 1.0) * 255.0).round() as u8);
    ([rgb[0], rgb[1], rgb[2], d as u8], m > RGBD_MAX)
}

/// What Babylon's `fromRGBD` reads back from RGBD bytes (before its half-float cube).
pub fn from_rgbd(b: [u8; 4]) -> [f32; 3] {
    let d = b[3] as f32 / 255.0;
    [b[0], b[1], b[2]].map(|v| (v as f32 / 255.0).powf(GAMMA) / d)
}

/// Face `f` of `c` as an RGBD PNG, and its count of clamped texels.
pub fn face_png(c: &Cubemap, f: usize, flip_rows: bool) -> Result<(Vec<u8>, usize), String> {
    let s = c.size;
    let mut bytes = Vec::with_capacity(s * s * 4);
    let mut overflow = 0;
    for row in 0..s {
        let y = if flip_rows { s - 1 - row } else { row };
        for x in 0..s {
            let i = (f * s + y) * s + x;
            let (b, over) = rgbd([c.data[3 * i], c.data[3 * i + 1], c.data[3 * i + 2]]);
            overflow += over as usize;
            bytes.extend_from_slice(&b);
        }
    }
    let mut png = Vec::new();
    PngEncoder::new(&mut png)
        .write_image(&bytes, s as u32, s as u32, ExtendedColorType::Rgba8)
        .map_err(|e| format!("PNG encoding failed: {e}"))?;
    Ok((png, overflow))
}

/// Every level's six faces as RGBD PNGs, level 0 first, faces +X -X +Y -Y +Z -Z (each of
/// [`face_png`]), and how many texels were beyond [`RGBD_MAX`] (clamped).
pub fn chain_pngs(levels: &[Cubemap], flip_rows: bool) -> Result<(Vec<Vec<u8>>, usize), String> {
    let faces: Vec<(usize, usize)> = (0..levels.len()).flat_map(|k| (0..6).map(move |f| (k, f))).collect();
    let encoded: Vec<Result<(Vec<u8>, usize), String>> =
        faces.par_iter().map(|&(k, f)| face_png(&levels[k], f, flip_rows)).collect();
    let mut images = Vec::with_capacity(encoded.len());
    let mut overflow = 0;
    for e in encoded {
        let (png, n) = e?;
        overflow += n;
        images.push(png);
    }
    Ok((images, overflow))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every value up to 255 comes back within RGBD's 8-bit step: with `g = (m D)^(1/2.2)` the
    /// stored largest channel and `h = 0.5 / 255` half a step, every channel is within
    /// `2.2 h (g + h)^1.2 / g^2.2` of the largest channel `m` (the mean value theorem on `g^2.2`);
    /// below 1.2% of it for `m >= 1` (where `g >= (254/255)^(1/2.2)`). Clamped beyond 255, and counted.
    #[test]
    fn rgbd_round_trip_is_within_its_step() {
        let h = 0.5 / 255.0;
        for i in 0..=4000 {
            let v = 1e-3 * 1.0025f32.powi(i);
            for c in [[v, v, v], [v, 0.5 * v, 0.1 * v], [0.0, v, 0.3 * v]] {
                let (b, over) = rgbd(c);
                let back = from_rgbd(b);
                let m = c.iter().fold(0.0f32, |a, &x| a.max(x));
                assert_eq!(over, m > RGBD_MAX, "{c:?}");
                if over {
                    continue;
                }
                let g = (m * b[3] as f32 / 255.0).powf(1.0 / GAMMA);
                let bound = GAMMA * h * (g + h).powf(GAMMA - 1.0) / g.powf(GAMMA) * 1.001;
                let err = (0..3).map(|k| (back[k] - c[k]).abs()).fold(0.0f32, f32::max) / m;
                assert!(err <= bound, "{c:?} -> {b:?} -> {back:?}: {err} > {bound}");
                if m >= 1.0 {
                    assert!(err < 0.012, "{c:?}: {err}");
                }
            }
        }
        assert_eq!(rgbd([1000.0, 0.0, 0.0]), ([255, 0, 0, 1], true));
        assert_eq!(rgbd([1.0, 0.0, f32::NAN]).0, [255, 0, 0, 255]);
    }
}
