//! PNG writers (write only): 8-bit sRGB previews of linear HDR images ([`PngFormat::Srgb8`], the
//! default), 16-bit linear data textures ([`PngFormat::Linear16`], a BRDF LUT) and PlayCanvas'
//! RGBP textures ([`PngFormat::Rgbp`], written by `formats::rgbp`).
//!
//! Pipeline per sample: `c * 2^stops` (exposure), the sRGB OETF of IEC 61966-2-1:1999
//!
//! ```text
//! V = 12.92 c                      for c <= 0.0031308
//! V = 1.055 c^(1/2.4) - 0.055      otherwise
//! ```
//!
//! then clamp to [0, 1], NaN and negatives -> 0, and round to the nearest of 0..=255
//! (so linear 0.5 -> 0.7354 -> 188, linear 1 -> 255): `srgb8::linear_to_srgb8`, here by its
//! table. No tone mapping beyond the clamp: a preview should show what is stored, and the
//! exposure is the one knob. Encoded as RGB8 (3 channels) or L8 (1 channel) by the `image`
//! crate's `PngEncoder`; the transfer runs in parallel over rows.
//!
//! `Linear16`: `c * 2^stops` clamped to [0, 1] (NaN -> 0) and rounded to the nearest of 0..=65535,
//! no transfer function (so 0.5 -> 32768). Channels as the 8-bit path, except that two colour
//! channels (a `BrdfLut`, `R G`) are written as RGB16 with B = 0, as glTF-IBL-Sampler writes its
//! LUT (three channels, R scale, G bias, B 0 for GGX, `lib/source/lib.cpp` `download2DImage`; it
//! writes 8 bits, row 0 = roughness 0, column = n.v, as `BrdfLut`'s rows and columns): grey ->
//! L16, grey + `A` -> LA16, RGB -> RGB16, RGBA -> RGBA16.

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use rayon::prelude::*;

use super::srgb8::Srgb8Table;
use super::FormatError;
use crate::values::Image;

crate::choice! {
    /// How `Save` writes an image as `.png`.
    #[derive(Default)]
    pub enum PngFormat {
        /// 8-bit sRGB preview: exposure, the sRGB transfer, clamped (to look at)
        #[default]
        Srgb8,
        /// 16-bit linear values clamped to [0, 1], no transfer (data such as a BRDF LUT; two channels as R, G, B = 0)
        Linear16,
        /// PlayCanvas' RGBP (8-bit RGBA, values up to 64, `formats::rgbp`; exposure not applied): its envAtlas and skybox textures
        Rgbp,
    }
}

/// Encodes `image` as an 8-bit sRGB PNG after multiplying by `2^exposure_stops`.
/// 1 channel -> greyscale (L8), 3 channels -> RGB8, 4 channels -> RGBA8 (alpha is coverage:
/// clamped to [0, 1], neither exposed nor sRGB-encoded); anything else is an error.
pub fn encode(image: &Image, exposure_stops: f64) -> Result<Vec<u8>, FormatError> {
    to_srgb8(image, exposure_stops)?.encode()
}

/// An image's 8-bit samples, ready to be compressed: the first step of [`encode`], apart so that
/// a caller can let go of the float image before the compression.
pub struct Srgb8 {
    bytes: Vec<u8>,
    width: u32,
    height: u32,
    color: ExtendedColorType,
}

/// The 8-bit samples of `image` after multiplying by `2^exposure_stops` (see [`encode`]).
pub fn to_srgb8(image: &Image, exposure_stops: f64) -> Result<Srgb8, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    if w == 0 || h == 0 {
        return Err(FormatError::Invalid(format!("cannot write an empty {w}x{h} image as PNG")));
    }
    let color = match c {
        1 => ExtendedColorType::L8,
        3 => ExtendedColorType::Rgb8,
        4 => ExtendedColorType::Rgba8,
        _ => return Err(FormatError::Invalid(format!("cannot write a {c}-channel image as PNG (1, 3 or 4)"))),
    };
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(FormatError::Invalid(format!("image too large for PNG: {w}x{h}")));
    };
    let n = w.checked_mul(h).and_then(|p| p.checked_mul(c));
    if n != Some(image.data.len()) {
        return Err(FormatError::Invalid(format!(
            "image buffer has {} samples, expected {w}x{h}x{c}",
            image.data.len()
        )));
    }
    let gain = exposure_stops.exp2();
    let table = Srgb8Table::new();
    let mut bytes = vec![0u8; image.data.len()];
    let row = w * c;
    bytes.par_chunks_mut(row).zip(image.data.par_chunks(row)).for_each(|(dst, src)| {
        for (k, (d, &s)) in dst.iter_mut().zip(src).enumerate() {
            *d = if c == 4 && k % 4 == 3 {
                // NaN alpha -> 0 (`clamp` keeps NaN; the cast maps it to 0).
                (s.clamp(0.0, 1.0) * 255.0).round() as u8
            } else {
                // 0 * Inf (a huge exposure on black) is NaN -> 0.
                table.code(s as f64 * gain)
            };
        }
    });
    Ok(Srgb8 { bytes, width: w32, height: h32, color })
}

impl Srgb8 {
    /// The PNG file: the samples compressed by the `image` crate's `PngEncoder`.
    pub fn encode(self) -> Result<Vec<u8>, FormatError> {
        let mut out = Vec::new();
        PngEncoder::new(&mut out)
            .write_image(&self.bytes, self.width, self.height, self.color)
            .map_err(|e| FormatError::Invalid(format!("PNG encoding failed: {e}")))?;
        Ok(out)
    }
}

/// Encodes `image` as a 16-bit linear PNG after multiplying by `2^exposure_stops` (see the module
/// docs; alpha is neither exposed nor transformed, only clamped).
pub fn encode_linear16(image: &Image, exposure_stops: f64) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    if w == 0 || h == 0 {
        return Err(FormatError::Invalid(format!("cannot write an empty {w}x{h} image as PNG")));
    }
    let grey_alpha = c == 2 && image.names[1] == "A";
    let (color, out_channels) = match c {
        1 => (ExtendedColorType::L16, 1),
        2 if grey_alpha => (ExtendedColorType::La16, 2),
        2 | 3 => (ExtendedColorType::Rgb16, 3),
        4 => (ExtendedColorType::Rgba16, 4),
        _ => return Err(FormatError::Invalid(format!("cannot write a {c}-channel image as PNG (1, 2, 3 or 4)"))),
    };
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(FormatError::Invalid(format!("image too large for PNG: {w}x{h}")));
    };
    if w.checked_mul(h).and_then(|p| p.checked_mul(c)) != Some(image.data.len()) {
        return Err(FormatError::Invalid(format!(
            "image buffer has {} samples, expected {w}x{h}x{c}",
            image.data.len()
        )));
    }
    let gain = exposure_stops.exp2();
    // NaN -> 0 (`clamp` keeps NaN; the cast maps it to 0), as 0 * Inf.
    let code = |v: f64| (v.clamp(0.0, 1.0) * 65535.0).round() as u16;
    let alpha = |k: usize| (c == 4 && k == 3) || (grey_alpha && k == 1);
    let mut bytes = vec![0u8; w * h * out_channels * 2];
    let row_in = w * c;
    bytes.par_chunks_mut(w * out_channels * 2).zip(image.data.par_chunks(row_in)).for_each(|(dst, src)| {
        for (x, px) in src.chunks_exact(c).enumerate() {
            for k in 0..out_channels {
                // Two colour channels: B = 0.
                let s = px.get(k).copied().unwrap_or(0.0) as f64;
                let v = if alpha(k) { code(s) } else { code(s * gain) };
                let at = 2 * (x * out_channels + k);
                dst[at..at + 2].copy_from_slice(&v.to_ne_bytes());
            }
        }
    });
    let mut out = Vec::new();
    PngEncoder::new(&mut out)
        .write_image(&bytes, w32, h32, color)
        .map_err(|e| FormatError::Invalid(format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodes_and_decodes_back() {
        let img = Image::from_vec(
            3,
            2,
            3,
            vec![
                0.5,
                0.0,
                f32::NAN, //
                0.25,
                1.0,
                100.0, //
                -1.0,
                f32::INFINITY,
                0.0, //
                0.0,
                0.0,
                0.0, //
                1.0,
                1.0,
                1.0, //
                0.5,
                0.5,
                0.5,
            ],
        );
        let png = encode(&img, 0.0).unwrap();
        let back = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), (3, 2));
        assert_eq!(back.get_pixel(0, 0).0, [188, 0, 0]);
        assert_eq!(back.get_pixel(1, 0).0, [137, 255, 255]);
        assert_eq!(back.get_pixel(2, 0).0, [0, 255, 0]);
        assert_eq!(back.get_pixel(0, 1).0, [0, 0, 0]);
        assert_eq!(back.get_pixel(1, 1).0, [255, 255, 255]);
        // Exposure: +1 stop turns 0.25 into 0.5 -> 188.
        let png = encode(&Image::from_vec(1, 1, 1, vec![0.25]), 1.0).unwrap();
        let back = image::load_from_memory(&png).unwrap();
        assert_eq!((back.width(), back.height()), (1, 1));
        assert_eq!(back.to_luma8().get_pixel(0, 0).0, [188]);
    }

    #[test]
    fn refuses_bad_shapes() {
        let message = |r: Result<Vec<u8>, FormatError>| r.unwrap_err().to_string();
        assert_eq!(message(encode(&Image::from_vec(0, 0, 3, vec![]), 0.0)), "cannot write an empty 0x0 image as PNG");
        assert_eq!(
            message(encode(&Image::from_vec(1, 1, 2, vec![0.0; 2]), 0.0)),
            "cannot write a 2-channel image as PNG (1, 3 or 4)"
        );
        assert_eq!(
            message(encode(
                &Image {
                    width: 2,
                    height: 1,
                    channels: 3,
                    names: crate::values::image::default_names(3),
                    data: vec![0.0; 3]
                },
                0.0
            )),
            "image buffer has 3 samples, expected 2x1x3"
        );
    }

    #[test]
    fn linear16_values_channels_and_orientation() {
        // A 2x2 two-channel LUT: row 0 first, B = 0, values clamped and rounded, NaN -> 0.
        let lut = Image::with_names(
            2,
            2,
            vec!["R".into(), "G".into()],
            vec![0.0, 1.0, 0.5, 0.25, 2.0, -1.0, f32::NAN, 1.0 / 65535.0],
        );
        let png = encode_linear16(&lut, 0.0).unwrap();
        let back = image::load_from_memory(&png).unwrap();
        assert_eq!(back.color(), image::ColorType::Rgb16);
        let back = back.to_rgb16();
        assert_eq!(back.get_pixel(0, 0).0, [0, 65535, 0]);
        assert_eq!(back.get_pixel(1, 0).0, [32768, 16384, 0]);
        assert_eq!(back.get_pixel(0, 1).0, [65535, 0, 0]);
        assert_eq!(back.get_pixel(1, 1).0, [0, 1, 0]);
        // Exposure scales colour, not alpha; grey, grey + alpha and RGBA keep their channels.
        let rgba = Image::with_names(1, 1, ["R", "G", "B", "A"].map(String::from).to_vec(), vec![0.25, 0.5, 1.0, 0.5]);
        let back = image::load_from_memory(&encode_linear16(&rgba, 1.0).unwrap()).unwrap();
        assert_eq!(back.color(), image::ColorType::Rgba16);
        assert_eq!(back.to_rgba16().get_pixel(0, 0).0, [32768, 65535, 65535, 32768]);
        let grey =
            image::load_from_memory(&encode_linear16(&Image::from_vec(1, 1, 1, vec![0.5]), 0.0).unwrap()).unwrap();
        assert_eq!((grey.color(), grey.to_luma16().get_pixel(0, 0).0), (image::ColorType::L16, [32768]));
        let ya = Image::with_names(1, 1, vec!["Y".into(), "A".into()], vec![0.5, 1.0]);
        let ya = image::load_from_memory(&encode_linear16(&ya, 0.0).unwrap()).unwrap();
        assert_eq!(ya.color(), image::ColorType::La16);
        let e = encode_linear16(&Image::from_vec(1, 1, 5, vec![0.0; 5]), 0.0).unwrap_err().to_string();
        assert_eq!(e, "cannot write a 5-channel image as PNG (1, 2, 3 or 4)");
        let e = encode_linear16(&Image::from_vec(0, 0, 3, vec![]), 0.0).unwrap_err().to_string();
        assert_eq!(e, "cannot write an empty 0x0 image as PNG");
        let short = Image {
            width: 2,
            height: 1,
            channels: 3,
            names: crate::values::image::default_names(3),
            data: vec![0.0; 3],
        };
        let e = encode_linear16(&short, 0.0).unwrap_err().to_string();
        assert_eq!(e, "image buffer has 3 samples, expected 2x1x3");
    }
}
