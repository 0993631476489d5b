//! 8-bit sRGB PNG previews of linear HDR images (write only).
//!
//! Pipeline per sample: `c * 2^stops` (exposure), the sRGB OETF of IEC 61966-2-1:1999
//!
//! ```text
//! V = 12.92 c                      for c <= 0.0031308
//! V = 1.055 c^(1/2.4) - 0.055      otherwise
//! ```
//!
//! then clamp to [0, 1], NaN and negatives -> 0, and round to the nearest of 0..=255
//! (so linear 0.5 -> 0.7354 -> 188, linear 1 -> 255). No tone mapping beyond the clamp: a preview
//! should show what is stored, and the exposure is the one knob. Encoded as RGB8 (3 channels) or
//! L8 (1 channel) by the `image` crate's `PngEncoder`; the transfer runs in parallel over rows.

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use rayon::prelude::*;

use super::FormatError;
use crate::values::Image;

/// Linear value -> 8-bit sRGB code (IEC 61966-2-1 OETF, clamped, NaN -> 0).
#[inline]
pub fn linear_to_srgb8(c: f64) -> u8 {
    if !(c > 0.0) {
        return 0; // negative, zero, NaN
    }
    if c >= 1.0 {
        return 255; // includes +Inf
    }
    let v = if c <= 0.0031308 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
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
    let table = super::srgb8::Srgb8Table::new();
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        assert_eq!(linear_to_srgb8(0.5), 188);
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(7.0), 255);
        assert_eq!(linear_to_srgb8(f64::NAN), 0);
        assert_eq!(linear_to_srgb8(f64::INFINITY), 255);
        assert_eq!(linear_to_srgb8(-3.0), 0);
        assert_eq!(linear_to_srgb8(0.001), 3); // linear segment: 12.92 * 0.001 * 255 = 3.29
    }

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
}
