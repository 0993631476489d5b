//! Photographs: PNG, JPEG and TIFF files of 8 or 16 bits per channel, as cameras and raw
//! converters write them, read as integer codes (what `LoadImage` and `LoadBrackets` start from).
//!
//! Decoding goes through the `image` crate's codecs, colour JPEGs through the one it wraps
//! ([`jpeg`], without `image`'s copy of the file). The file's EXIF orientation (tags 1-8, as
//! the decoder reports it) is applied, so row 0 is the top of the scene as the camera was held;
//! grey is expanded to RGB and alpha dropped, so every photograph is RGB interleaved. Floating
//! point TIFFs are refused (`LoadHdr` reads HDR files). The camera settings come from the EXIF
//! block, read by `kamadak-exif` ([`exif`]); a missing or broken block gives empty settings, never
//! an error (a PNG from an editor has none).
//!
//! [`header`] reads the size and bit depth without decoding the pixels, so validation can check
//! sizes before a run. [`encode`] writes frames back as PNG, JPEG or TIFF with their exposure time
//! in EXIF, so that a saved bracket loads again.

pub mod encode;
pub mod exif;
mod jpeg;

use std::io::{BufRead, BufReader, Cursor, Seek};
use std::path::Path;

use image::metadata::Orientation;
use image::{ColorType, DynamicImage, ImageDecoder, ImageFormat, ImageReader};

use crate::values::brackets::Codes;
use crate::values::Exif;

/// The file extensions of photographs (lower case), as a folder of brackets is listed.
pub const EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "tif", "tiff"];

/// What a photograph's header says: its size once its orientation is applied, and its bits per
/// channel (8 or 16).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub width: usize,
    pub height: usize,
    pub bit_depth: u8,
}

/// A decoded photograph: RGB codes, row 0 at the top, orientation applied, and its EXIF settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Photo {
    pub width: usize,
    pub height: usize,
    pub codes: Codes,
    pub exif: Exif,
}

/// The bits per channel of a decoder's colour type, or why it is not a photograph we read.
fn bit_depth(color: ColorType) -> Result<u8, String> {
    match color {
        ColorType::L8 | ColorType::La8 | ColorType::Rgb8 | ColorType::Rgba8 => Ok(8),
        ColorType::L16 | ColorType::La16 | ColorType::Rgb16 | ColorType::Rgba16 => Ok(16),
        other => Err(format!(
            "has {other:?} samples: photographs of 8 or 16 bits per channel are read (LoadHdr reads float images)"
        )),
    }
}

/// The stored size turned as `o` turns it (a quarter turn swaps width and height).
fn oriented(width: u32, height: u32, o: Orientation) -> (usize, usize) {
    let (w, h) = (width as usize, height as usize);
    match o {
        Orientation::Rotate90 | Orientation::Rotate270 | Orientation::Rotate90FlipH | Orientation::Rotate270FlipH => {
            (h, w)
        }
        _ => (w, h),
    }
}

/// The size (orientation applied) and bit depth from the file's header, without decoding pixels.
/// Errors are phrased to follow the file's name ("is not an image ...").
pub fn header(path: &Path) -> Result<Header, String> {
    let unreadable = |e: std::io::Error| format!("cannot be read: {e}");
    let mut reader = BufReader::new(std::fs::File::open(path).map_err(unreadable)?);
    if is_jpeg(reader.fill_buf().map_err(unreadable)?) {
        if let Some(s) = jpeg::header(&mut reader)? {
            let (width, height) = oriented(s.width as u32, s.height as u32, s.orientation);
            return Ok(Header { width, height, bit_depth: 8 });
        }
        reader.rewind().map_err(unreadable)?;
    }
    let reader = ImageReader::new(reader).with_guessed_format().map_err(unreadable)?;
    format_of_reader(&reader)?;
    let mut decoder = reader.into_decoder().map_err(|e| format!("is not a readable image: {e}"))?;
    let bit_depth = bit_depth(decoder.color_type())?;
    let orientation = decoder.orientation().unwrap_or(Orientation::NoTransforms);
    let (w, h) = decoder.dimensions();
    let (width, height) = oriented(w, h, orientation);
    Ok(Header { width, height, bit_depth })
}

/// Whether `bytes` (a file's first ones) are a JPEG's, by `image`'s own test.
fn is_jpeg(bytes: &[u8]) -> bool {
    matches!(image::guess_format(bytes), Ok(ImageFormat::Jpeg))
}

/// PNG, JPEG or TIFF by the file's first bytes, else why not.
fn format_of_reader<R: std::io::BufRead + std::io::Seek>(reader: &ImageReader<R>) -> Result<ImageFormat, String> {
    match reader.format() {
        Some(f @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::Tiff)) => Ok(f),
        Some(other) => Err(format!("is a {other:?} file, not a PNG, JPEG or TIFF photograph")),
        None => Err("is not an image (not a PNG, JPEG or TIFF file)".into()),
    }
}

/// Decodes a photograph's bytes: RGB codes (grey expanded, alpha dropped), orientation applied,
/// and its EXIF settings. Errors are phrased to follow the file's name.
pub fn decode(bytes: &[u8]) -> Result<Photo, String> {
    let colour_jpeg = if is_jpeg(bytes) { jpeg::decode(bytes)? } else { None };
    let (mut img, bits, orientation) = match colour_jpeg {
        Some((s, codes)) => {
            let stored = image::RgbImage::from_raw(s.width as u32, s.height as u32, codes)
                .ok_or("is not a readable image: its size does not match its data")?;
            (DynamicImage::ImageRgb8(stored), 8, s.orientation)
        }
        None => {
            let reader = ImageReader::new(Cursor::new(bytes))
                .with_guessed_format()
                .map_err(|e| format!("cannot be read: {e}"))?;
            format_of_reader(&reader)?;
            let mut decoder = reader.into_decoder().map_err(|e| format!("is not a readable image: {e}"))?;
            let bits = bit_depth(decoder.color_type())?;
            let orientation = decoder.orientation().unwrap_or(Orientation::NoTransforms);
            let img = DynamicImage::from_decoder(decoder).map_err(|e| format!("is not a readable image: {e}"))?;
            (img, bits, orientation)
        }
    };
    img.apply_orientation(orientation);
    let (width, height) = (img.width() as usize, img.height() as usize);
    let codes = match bits {
        8 => Codes::U8(img.into_rgb8().into_raw()),
        _ => Codes::U16(img.into_rgb16().into_raw()),
    };
    Ok(Photo { width, height, codes, exif: exif::read(bytes) })
}
