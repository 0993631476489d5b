//! `LoadImage(path, encoding: Auto)`: a photograph (PNG, JPEG or TIFF, 8 or 16 bits per channel)
//! as a float RGB image, and its EXIF settings.
//!
//! The file is read by `crate::formats::photo`: its EXIF orientation (1-8) applied, grey
//! expanded to RGB, alpha dropped. Each code c of a file whose largest code is m (255 or 65535)
//! becomes, by `encoding`:
//! - `Srgb`: the IEC 61966-2-1 decoding of c / m to linear [0, 1] (`maths::capture::codes`);
//! - `Linear`: c / m, the file taken as linear already;
//! - `Codes`: c itself (0..=255 or 0..=65535 as floats), what a response calibration reads;
//! - `Auto`: `Srgb` for 8-bit files and `Linear` for 16-bit ones. 8-bit JPEGs and PNGs are
//!   display-encoded (cameras and editors write sRGB), while 16-bit TIFFs and PNGs are what raw
//!   converters export for merging (dcraw `-4`, darktable and RawTherapee's linear output), whose
//!   codes are proportional to the light; an sRGB-encoded 16-bit file needs `encoding: Srgb`.
//!
//! Port `exif`: exposure time, f-number, ISO, make and model, where the file gives them.
//! The cache key is the file's BLAKE3 content hash (plus the encoding, a field), never its
//! path; the size comes from the header at validation, so sizes downstream are checked before
//! any pixel is decoded.

use std::path::Path;

use crate::engine::fields::Check;
use crate::engine::op::{resolve_path, CheckContext, OpContext, OpError, OpSpec, Outputs, Size};
use crate::engine::params::InputPath;
use crate::engine::typed_op::{Op, Port};
use crate::formats::photo;
use crate::maths::capture::codes::{table, CodeScale};
use crate::values::brackets::Codes;
use crate::values::ty::*;
use crate::values::{Exif, Image};

crate::choice! {
    /// How a photograph's codes become floats.
    pub enum Encoding { Auto, Srgb, Linear, Codes }
}

crate::params! {
    pub struct LoadImageParams {
        /// a PNG, JPEG or TIFF file (8 or 16 bits per channel), relative to the pipeline file
        pub path: InputPath,
        /// Srgb (decoded to linear), Linear (code / max), Codes (0..255 or 0..65535 as floats), or Auto: Srgb for 8-bit files, Linear for 16-bit
        pub encoding: Encoding = Encoding::Auto,
    }
}

const IMAGE: Port<Image> = Port::new("image");
const EXIF: Port<Exif> = Port::new("exif");

pub fn spec() -> OpSpec {
    Op::new(
        "LoadImage",
        1,
        "Load a photograph (PNG, JPEG, TIFF; 8 or 16 bits) as float RGB, EXIF orientation applied, with its EXIF settings",
        eval,
    )
    .port(IMAGE, IMAGE_T, "float RGB: linear [0, 1] (Srgb, Linear) or the codes (Codes)")
    .port(EXIF, EXIF_T, "exposure time, f-number, ISO, make and model, where the file gives them")
    .size(size)
    .content_key(content_key)
    .into()
}

/// The scale an encoding gives a file of `bit_depth` bits.
pub fn scale(encoding: Encoding, bit_depth: u8) -> CodeScale {
    match encoding {
        Encoding::Auto if bit_depth == 8 => CodeScale::Srgb,
        Encoding::Auto => CodeScale::Linear,
        Encoding::Srgb => CodeScale::Srgb,
        Encoding::Linear => CodeScale::Linear,
        Encoding::Codes => CodeScale::Codes,
    }
}

/// The codes as floats through the table of `scale`.
pub fn to_floats(codes: &Codes, scale: CodeScale) -> Vec<f32> {
    match codes {
        Codes::U8(v) => {
            let t = table(u8::MAX as u16, scale);
            v.iter().map(|&c| t[c as usize]).collect()
        }
        Codes::U16(v) => {
            let t = table(u16::MAX, scale);
            v.iter().map(|&c| t[c as usize]).collect()
        }
    }
}

fn content_key(p: LoadImageParams<Check>, base_dir: &Path) -> Result<Vec<u8>, OpError> {
    let full = resolve_path(base_dir, &p.path.0);
    let bytes =
        crate::memory::read_file_unpooled(&full).map_err(|source| OpError::Io { path: full.clone(), source })?;
    Ok(blake3::hash(&bytes).as_bytes().to_vec())
}

fn eval(ctx: &mut OpContext, p: LoadImageParams) -> Result<Outputs, OpError> {
    let full = ctx.path(&p.path.0);
    let bytes =
        crate::memory::read_file_unpooled(&full).map_err(|source| OpError::Io { path: full.clone(), source })?;
    // The key was made from the file's hash before the run; decoding other bytes would cache
    // them under that key.
    if ctx.content_key.is_some_and(|key| key != blake3::hash(&bytes).as_bytes()) {
        return Err(OpError::Invalid(format!("{} changed while hdrflow was running; run again", full.display())));
    }
    let photo =
        photo::decode(&bytes).map_err(|m| OpError::Format { path: full.clone(), message: format!("the file {m}") })?;
    drop(bytes);
    let data = to_floats(&photo.codes, scale(p.encoding, photo.codes.bits()));
    let image = Image::from_vec(photo.width, photo.height, 3, data);
    Ok(Outputs::new().port(IMAGE, image).port(EXIF, photo.exif))
}

/// The size from the file's header, orientation applied (none when the header cannot be read:
/// the run's error then names the file).
fn size(ctx: &CheckContext, p: LoadImageParams<Check>) -> Size {
    let h = photo::header(&resolve_path(ctx.base_dir, &p.path.0)).ok()?;
    let (w, h) = (h.width as u64, h.height as u64);
    w.checked_mul(h).is_some_and(|n| n <= crate::engine::op::MAX_PIXELS).then_some((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_is_srgb_for_8_bits_and_linear_for_16() {
        assert_eq!(scale(Encoding::Auto, 8), CodeScale::Srgb);
        assert_eq!(scale(Encoding::Auto, 16), CodeScale::Linear);
        assert_eq!(scale(Encoding::Codes, 8), CodeScale::Codes);
        let f = to_floats(&Codes::U8(vec![0, 128, 255]), CodeScale::Srgb);
        assert_eq!((f[0], f[2]), (0.0, 1.0));
        assert!((f[1] - 0.215861).abs() < 1e-6);
        assert_eq!(to_floats(&Codes::U16(vec![0, 65535]), CodeScale::Codes), [0.0, 65535.0]);
    }
}
