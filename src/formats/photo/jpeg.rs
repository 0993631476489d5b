//! Colour JPEGs decoded by `zune-jpeg`, the decoder the `image` crate wraps, straight from the
//! file's bytes (or, for the header, from the open file).
//!
//! Why not through `image`: its `JpegDecoder` first copies the whole file into a buffer of its own,
//! for the header too, and that buffer, once freed, stays resident in the decoding thread's heap
//! (see `memory::read_file_unpooled`). Only colour files (YCbCr or RGB, what cameras write) take
//! this path, with the options `image` gives the decoder, so they decode to the same codes (test);
//! grey and CMYK files are left to `image`.

use std::io::{BufRead, Seek};

use image::metadata::Orientation;
use zune_core::bytestream::{ZByteReaderTrait, ZCursor};
use zune_core::colorspace::ColorSpace;
use zune_core::options::DecoderOptions;
use zune_jpeg::errors::DecodeErrors;
use zune_jpeg::JpegDecoder;

/// The stored size of a colour JPEG and the orientation its EXIF block gives.
pub struct Stored {
    pub width: usize,
    pub height: usize,
    pub orientation: Orientation,
}

fn options() -> DecoderOptions {
    DecoderOptions::default()
        .set_strict_mode(false)
        .set_max_width(usize::MAX)
        .set_max_height(usize::MAX)
        .jpeg_set_out_colorspace(ColorSpace::RGB)
}

/// zune's error as a sentence: its `Display` of a format error is the quoted `Debug` of the
/// message, so those two are unwrapped.
fn unreadable(e: DecodeErrors) -> String {
    let message = match e {
        DecodeErrors::Format(m) => m,
        DecodeErrors::FormatStatic(m) => m.to_owned(),
        other => other.to_string(),
    };
    format!("is not a readable image: {message}")
}

/// Reads the headers: `None` for a grey or CMYK file, which `image` decodes instead.
fn stored<T: ZByteReaderTrait>(decoder: &mut JpegDecoder<T>) -> Result<Option<Stored>, String> {
    decoder.decode_headers().map_err(unreadable)?;
    if !matches!(decoder.input_colorspace(), Some(ColorSpace::YCbCr | ColorSpace::RGB)) {
        return Ok(None);
    }
    let Some((width, height)) = decoder.dimensions() else {
        return Ok(None);
    };
    let orientation =
        decoder.exif().and_then(|chunk| Orientation::from_exif_chunk(chunk)).unwrap_or(Orientation::NoTransforms);
    Ok(Some(Stored { width, height, orientation }))
}

/// The header of a colour JPEG, read from `reader` without loading the file.
pub fn header<R: BufRead + Seek>(reader: R) -> Result<Option<Stored>, String> {
    stored(&mut JpegDecoder::new_with_options(reader, options()))
}

/// A colour JPEG's RGB codes as stored (orientation not applied) and its header, or `None`.
pub fn decode(bytes: &[u8]) -> Result<Option<(Stored, Vec<u8>)>, String> {
    let mut decoder = JpegDecoder::new_with_options(ZCursor::new(bytes), options());
    let Some(s) = stored(&mut decoder)? else {
        return Ok(None);
    };
    let len = s.width.checked_mul(s.height).and_then(|n| n.checked_mul(3)).ok_or("is too large to decode")?;
    let mut codes = vec![0u8; len];
    decoder.decode_into(&mut codes).map_err(unreadable)?;
    Ok(Some((s, codes)))
}

#[cfg(test)]
mod tests {
    use image::{DynamicImage, ImageFormat, RgbImage};

    use super::*;

    /// A colour JPEG decodes to `image`'s codes, and a grey one is left to `image`.
    #[test]
    fn codes_match_the_image_crate() {
        let (w, h) = (37u32, 21u32);
        let rgb = RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 7) as u8, (y * 11) as u8, ((x + y) * 5) as u8]));
        let mut file = Vec::new();
        DynamicImage::ImageRgb8(rgb).write_to(&mut std::io::Cursor::new(&mut file), ImageFormat::Jpeg).unwrap();
        assert!(super::super::is_jpeg(&file));
        let (s, codes) = decode(&file).unwrap().unwrap();
        assert_eq!((s.width, s.height), (w as usize, h as usize));
        assert!(matches!(s.orientation, Orientation::NoTransforms));
        let theirs = image::load_from_memory_with_format(&file, ImageFormat::Jpeg).unwrap().into_rgb8().into_raw();
        assert_eq!(codes, theirs);

        let grey = image::GrayImage::from_fn(w, h, |x, _| image::Luma([(x * 6) as u8]));
        let mut file = Vec::new();
        DynamicImage::ImageLuma8(grey).write_to(&mut std::io::Cursor::new(&mut file), ImageFormat::Jpeg).unwrap();
        assert!(decode(&file).unwrap().is_none());
        assert!(decode(b"\xFF\xD8\xFF not a jpeg").is_err());
    }

    /// A JPEG whose EXIF says orientation 6 (the camera turned a quarter clockwise) decodes, by
    /// `photo::decode` and `photo::header`, as `image` decodes and turns it, with its time read.
    #[test]
    fn the_exif_orientation_is_applied() {
        use ::exif::{experimental::Writer, Field, In, Rational, Tag, Value};
        use image::{ImageDecoder, ImageEncoder};
        let (w, h) = (40u32, 24u32);
        let rgb = RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 6) as u8, (y * 10) as u8, 128]));
        let fields = [
            Field { tag: Tag::Orientation, ifd_num: In::PRIMARY, value: Value::Short(vec![6]) },
            Field {
                tag: Tag::ExposureTime,
                ifd_num: In::PRIMARY,
                value: Value::Rational(vec![Rational::from((1, 125))]),
            },
        ];
        let mut writer = Writer::new();
        fields.iter().for_each(|f| writer.push_field(f));
        let mut block = std::io::Cursor::new(Vec::new());
        writer.write(&mut block, false).unwrap();
        let mut file = Vec::new();
        let mut e = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut file, 95);
        e.set_exif_metadata(block.into_inner()).unwrap();
        e.write_image(rgb.as_raw(), w, h, image::ExtendedColorType::Rgb8).unwrap();

        let photo = super::super::decode(&file).unwrap();
        let mut decoder =
            image::ImageReader::with_format(std::io::Cursor::new(&file), ImageFormat::Jpeg).into_decoder().unwrap();
        let orientation = decoder.orientation().unwrap();
        assert!(matches!(orientation, Orientation::Rotate90));
        let mut theirs = DynamicImage::from_decoder(decoder).unwrap();
        theirs.apply_orientation(orientation);
        assert_eq!((photo.width, photo.height), (h as usize, w as usize));
        assert_eq!(photo.codes, crate::values::brackets::Codes::U8(theirs.into_rgb8().into_raw()));
        assert_eq!(photo.exif.exposure_time, Some(1.0 / 125.0));

        let path = std::env::temp_dir().join(format!("hdrflow-jpeg-orientation-{}.jpg", std::process::id()));
        std::fs::write(&path, &file).unwrap();
        let header = super::super::header(&path);
        std::fs::remove_file(&path).unwrap();
        assert_eq!(header.unwrap(), super::super::Header { width: h as usize, height: w as usize, bit_depth: 8 });
    }

    /// A file that starts as a JPEG and breaks off is an error in plain words (zune's format
    /// errors used to reach the user in quotes).
    #[test]
    fn a_broken_jpeg_is_an_error_without_quotes() {
        for bytes in [&b"\xFF\xD8\xFF\xD9"[..], &b"\xFF\xD8\xFF\xC0\x00\x11\x08"[..]] {
            let e = decode(bytes).err().expect("a broken JPEG is an error");
            assert!(e.starts_with("is not a readable image: ") && !e.contains('"'), "{e}");
        }
    }
}
