//! Writing one frame of codes as a photograph with its exposure time in EXIF, so that
//! `LoadBrackets` reads the saved frames back with their times: PNG (8 or 16 bits, an `eXIf`
//! chunk) and JPEG (8 bits, quality [`JPEG_QUALITY`], an APP1 `Exif` segment), both through the
//! `image` crate's encoders, which place the block; TIFF (8 or 16 bits, uncompressed RGB strips)
//! written whole by `kamadak-exif`'s TIFF writer, the ExposureTime in its Exif sub-IFD, the
//! same place a camera's TIFF has it.

use std::io::Cursor;

use ::exif::{Field, In, Tag, Value};
use image::codecs::jpeg::JpegEncoder;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use super::exif::{block, exposure_field};
use crate::values::brackets::Codes;

/// JPEG quality of saved frames: high, since the frames feed a response calibration.
pub const JPEG_QUALITY: u8 = 95;

/// TIFF strips of about this many bytes (the writer keeps each strip's offset and length).
const STRIP_BYTES: usize = 1 << 16;

/// One frame (`width x height` RGB codes) as a file of extension `ext` (`png`, `jpg`/`jpeg`,
/// `tif`/`tiff`) whose EXIF gives `time` seconds.
pub fn encode_frame(width: usize, height: usize, codes: &Codes, time: f64, ext: &str) -> Result<Vec<u8>, String> {
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(format!("a {width}x{height} frame is too large for a photograph"));
    };
    if width == 0 || height == 0 || codes.len() != width * height * 3 {
        return Err(format!("a {width}x{height} frame has {} samples", codes.len()));
    }
    let mut out = Vec::new();
    match ext {
        "png" => {
            let mut e = PngEncoder::new(&mut out);
            e.set_exif_metadata(block(time)?).map_err(|e| e.to_string())?;
            let (bytes, color) = native_bytes(codes);
            e.write_image(&bytes, w, h, color).map_err(|e| format!("PNG encoding failed: {e}"))?;
        }
        "jpg" | "jpeg" => {
            let Codes::U8(v) = codes else {
                return Err("JPEG holds 8 bits per channel: save 16-bit frames as .png or .tif".into());
            };
            let mut e = JpegEncoder::new_with_quality(&mut out, JPEG_QUALITY);
            e.set_exif_metadata(block(time)?).map_err(|e| e.to_string())?;
            e.write_image(v, w, h, ExtendedColorType::Rgb8).map_err(|e| format!("JPEG encoding failed: {e}"))?;
        }
        "tif" | "tiff" => out = tiff(w, h, codes, time)?,
        other => return Err(format!("a frame cannot be written as .{other} (use .png, .jpg or .tif)")),
    }
    Ok(out)
}

/// The codes as the bytes `image`'s encoders take (16-bit samples in native byte order).
fn native_bytes(codes: &Codes) -> (std::borrow::Cow<'_, [u8]>, ExtendedColorType) {
    match codes {
        Codes::U8(v) => (v.as_slice().into(), ExtendedColorType::Rgb8),
        Codes::U16(v) => (v.iter().flat_map(|c| c.to_ne_bytes()).collect::<Vec<u8>>().into(), ExtendedColorType::Rgb16),
    }
}

/// A baseline uncompressed RGB TIFF (little-endian, chunky, strips of about [`STRIP_BYTES`]).
fn tiff(w: u32, h: u32, codes: &Codes, time: f64) -> Result<Vec<u8>, String> {
    let bits = codes.bits() as u16;
    let bytes: Vec<u8> = match codes {
        Codes::U8(v) => v.clone(),
        Codes::U16(v) => v.iter().flat_map(|c| c.to_le_bytes()).collect(),
    };
    let row = w as usize * 3 * (bits as usize / 8);
    let rows_per_strip = (STRIP_BYTES / row).clamp(1, h as usize);
    let strips: Vec<&[u8]> = bytes.chunks(row * rows_per_strip).collect();
    let short = |tag: Tag, v: Vec<u16>| Field { tag, ifd_num: In::PRIMARY, value: Value::Short(v) };
    let long = |tag: Tag, v: u32| Field { tag, ifd_num: In::PRIMARY, value: Value::Long(vec![v]) };
    let fields = [
        long(Tag::ImageWidth, w),
        long(Tag::ImageLength, h),
        short(Tag::BitsPerSample, vec![bits; 3]),
        short(Tag::Compression, vec![1]),
        short(Tag::PhotometricInterpretation, vec![2]),
        short(Tag::SamplesPerPixel, vec![3]),
        long(Tag::RowsPerStrip, rows_per_strip as u32),
        short(Tag::PlanarConfiguration, vec![1]),
        exposure_field(time)?,
    ];
    let mut writer = ::exif::experimental::Writer::new();
    for f in &fields {
        writer.push_field(f);
    }
    writer.set_strips(&strips, In::PRIMARY);
    let mut out = Cursor::new(Vec::new());
    writer.write(&mut out, true).map_err(|e| format!("TIFF encoding failed: {e}"))?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_format_decodes_to_its_codes_and_time() {
        let (w, h) = (5, 3);
        let c8 = Codes::U8((0..w * h * 3).map(|i| (i * 17 % 256) as u8).collect());
        let c16 = Codes::U16((0..w * h * 3).map(|i| (i * 4099 % 65536) as u16).collect());
        for (codes, ext, lossless) in
            [(&c8, "png", true), (&c16, "png", true), (&c8, "tif", true), (&c16, "tiff", true), (&c8, "jpg", false)]
        {
            let bytes = encode_frame(w, h, codes, 1.0 / 60.0, ext).unwrap();
            let photo = super::super::decode(&bytes).unwrap_or_else(|e| panic!("{ext}: {e}"));
            assert_eq!((photo.width, photo.height, photo.codes.bits()), (w, h, codes.bits()), "{ext}");
            if lossless {
                assert_eq!(&photo.codes, codes, "{ext} {}", codes.bits());
            }
            assert_eq!(photo.exif.exposure_time, Some(1.0 / 60.0), "{ext}");
        }
        assert!(encode_frame(w, h, &c16, 1.0, "jpg").unwrap_err().contains("JPEG holds 8 bits"));
        assert!(encode_frame(w, h, &c8, 1.0, "bmp").is_err());
        assert!(encode_frame(w, h + 1, &c8, 1.0, "png").is_err());
    }
}
