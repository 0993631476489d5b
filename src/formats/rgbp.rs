//! RGBP, the 8-bit packing of HDR texels PlayCanvas reads from its `envAtlas` and skybox PNGs
//! (`TEXTURETYPE_RGBP`, `type: 'rgbp'` of a texture asset). PlayCanvas' shader chunks
//! (playcanvas/engine at commit 0aaef5e, as npm 2.23.3 ships them;
//! `src/scene/shader-lib/glsl/chunks/common/frag/encode.js` lines 22-36, `decode.js` lines 27-30):
//!
//! ```text
//! encodeRGBP(c): g = sqrt(c)                          (the "gamma(ish)" half power)
//!                m = clamp(max(g.r, g.g, g.b), 1, 8)
//!                v = ceil((1 - (m - 1) / 7) * 255) / 255
//!                RGBA = (g / (8 - 7 v), v)
//! decodeRGBP(RGBA) = (RGB (8 - 7 A))^2
//! ```
//!
//! So values up to 8^2 = 64 fit: A = 1 below 1 (plain sqrt-encoded 8-bit), and the multiplier
//! `8 - 7 A` grows to 8 as A falls to 0. A texel brighter than 64 is clamped (its colour kept,
//! its level 64) and counted. The RGB bytes are rounded to the nearest of 0..=255, as a GPU's
//! float-to-unorm conversion does when PlayCanvas renders its own atlas.

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use crate::values::Image;

/// The largest value RGBP holds: the multiplier's 8, squared.
pub const RGBP_MAX: f32 = 64.0;

/// One linear RGB value as RGBP bytes, and whether it was beyond [`RGBP_MAX`] (then clamped,
/// colour kept). Negative and non-finite channels count as 0.
pub fn rgbp(c: [f32; 3]) -> ([u8; 4], bool) {
    let c = c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
    let m = c[0].max(c[1]).max(c[2]);
    let over = m > RGBP_MAX;
    let c = if over { c.map(|v| v * (RGBP_MAX / m)) } else { c };
    let g = c.map(f32::sqrt);
    let max = g[0].max(g[1]).max(g[2]).clamp(1.0, 8.0);
    let v = ((1.0 - (max - 1.0) / 7.0) * 255.0).ceil() / 255.0;
    let scale = 8.0 - 7.0 * v;
    let rgb = g.map(|x| ((x / scale).clamp(0.0, 1.0) * 255.0).round() as u8);
    ([rgb[0], rgb[1], rgb[2], (v * 255.0).round() as u8], over)
}

/// What PlayCanvas' `decodeRGBP` reads back from RGBP bytes.
pub fn from_rgbp(b: [u8; 4]) -> [f32; 3] {
    let a = b[3] as f32 / 255.0;
    [b[0], b[1], b[2]].map(|v| {
        let x = v as f32 / 255.0 * (8.0 - 7.0 * a);
        x * x
    })
}

/// An RGB (or RGBA: alpha ignored) image as an RGBP PNG, row 0 first (PlayCanvas uploads PNGs
/// without flipping: `Texture`'s `flipY` defaults to false, so row 0 is texture v = 0), and its
/// count of clamped texels.
pub fn encode_png(img: &Image) -> Result<(Vec<u8>, usize), String> {
    if img.channels < 3 {
        return Err(format!("RGBP needs an RGB image, not {} channel(s)", img.channels));
    }
    let mut bytes = Vec::with_capacity(img.width * img.height * 4);
    let mut overflow = 0;
    for p in img.data.chunks_exact(img.channels) {
        let (b, over) = rgbp([p[0], p[1], p[2]]);
        overflow += over as usize;
        bytes.extend_from_slice(&b);
    }
    let mut png = Vec::new();
    PngEncoder::new(&mut png)
        .write_image(&bytes, img.width as u32, img.height as u32, ExtendedColorType::Rgba8)
        .map_err(|e| format!("PNG encoding failed: {e}"))?;
    Ok((png, overflow))
}

/// [`beyond_rgbp`] of interleaved RGB texels (a cube map's data).
pub fn beyond_rgbp_rgb(rgb: &[f32]) -> usize {
    rgb.chunks_exact(3).filter(|p| rgbp([p[0], p[1], p[2]]).1).count()
}

/// How many texels of `img` are beyond [`RGBP_MAX`] (what [`encode_png`] clamps).
pub fn beyond_rgbp(img: &Image) -> usize {
    let rgb = |p: &[f32]| [0, 1, 2].map(|k| p[k.min(p.len() - 1)]);
    img.data.chunks_exact(img.channels.max(1)).filter(|p| rgbp(rgb(p)).1).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Encoding then PlayCanvas' decoding gives the value back within the 8-bit step: below 1
    /// the step of sqrt at 1/255, above it the multiplier's step too.
    #[test]
    fn encode_then_decode_round_trips_within_the_8_bit_step() {
        for &x in &[0.0f32, 1e-4, 0.01, 0.2, 0.5, 0.99, 1.0, 1.5, 3.0, 10.0, 33.3, 63.0, 64.0] {
            for c in [[x, x, x], [x, 0.5 * x, 0.1 * x]] {
                let (b, over) = rgbp(c);
                assert!(!over);
                let d = from_rgbp(b);
                for k in 0..3 {
                    // d(g^2) = 2 g dg, dg <= (8 - 7a) / 510 plus the multiplier's rounding.
                    let g = c[k].sqrt();
                    let tol = 2.0 * g * 8.0 / 255.0 + 1e-5;
                    assert!((d[k] - c[k]).abs() <= tol, "{c:?} -> {b:?} -> {d:?}");
                }
            }
        }
        // Below 1: alpha 255 and the bytes are round(255 sqrt(c)).
        assert_eq!(rgbp([0.25, 1.0, 0.0]).0, [128, 255, 0, 255]);
        // 64: the multiplier 8, alpha 0.
        assert_eq!(rgbp([64.0, 0.0, 0.0]).0, [255, 0, 0, 0]);
        assert_eq!(from_rgbp([255, 0, 0, 0]), [64.0, 0.0, 0.0]);
    }

    /// PlayCanvas' own formula, step by step, for a value where the ceil matters.
    #[test]
    fn alpha_is_rounded_up_as_playcanvas_does() {
        let c = [9.0f32, 4.0, 1.0];
        // g = (3, 2, 1); m = 3; v = ceil((1 - 2/7) 255) / 255 = ceil(182.14) / 255 = 183 / 255.
        let (b, _) = rgbp(c);
        assert_eq!(b[3], 183);
        let scale = 8.0 - 7.0 * 183.0 / 255.0;
        assert_eq!(b[0], ((3.0 / scale) * 255.0f32).round() as u8);
    }

    #[test]
    fn values_beyond_64_are_clamped_with_their_colour_and_counted() {
        let (b, over) = rgbp([640.0, 320.0, 0.0]);
        assert!(over);
        let d = from_rgbp(b);
        assert!((d[0] - 64.0).abs() < 1e-3 && (d[1] - 32.0).abs() < 0.5, "{d:?}");
        let mut img = Image::new(2, 1, 3);
        img.data[0] = 100.0;
        assert_eq!(beyond_rgbp(&img), 1);
        assert_eq!(encode_png(&img).unwrap().1, 1);
    }
}
