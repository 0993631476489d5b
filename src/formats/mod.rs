//! Image file formats: readers and writers for the HDR formats hdrflow consumes and produces.
//!
//! | module      | format                          | read | write | notes |
//! |-------------|---------------------------------|------|-------|-------|
//! | [`rgbe`]    | Radiance `.hdr` / `.pic` (RGBE)  | yes  | yes   | hand-written, new-style RLE + flat + old `1 1 1 n` |
//! | [`pfm`]     | Portable Float Map `.pfm`        | yes  | yes   | hand-written (the `image` crate has no PFM) |
//! | [`exr`]     | OpenEXR `.exr`                   | yes  | yes   | through the `exr` crate, any sample type, any channel order |
//! | [`ktx2`]    | Khronos KTX 2.0 `.ktx2`          | no   | yes   | RGBA16F/RGBA32F, 2D or cube, mip levels in one file |
//! | [`png`]     | PNG (8-bit sRGB preview)         | no   | yes   | exposure + sRGB OETF, through the `image` crate |
//! | [`builtin`] | procedural lat-long maps         | -    | -     | so that everything runs with no data files |
//!
//! Every reader returns a [`crate::data::Image`]: f32 samples, row 0 at the top, 1 or 3 channels.
//! f32 (not f16) in memory because real suns exceed the half-float maximum of 65504
//! (`../shared/NOTES.md`, "Formats": the park map's sun is 69120).
//!
//! Every reader treats its input as hostile: it never panics, never indexes out of bounds, and
//! refuses a header that claims more than [`MAX_PIXELS`] pixels, or more pixels than the bytes that
//! follow could possibly encode, *before* allocating anything proportional to the claimed size.
//! Errors are a plain [`FormatError`] message; the caller adds the file name.

pub mod builtin;
pub mod exr;
pub mod ktx2;
pub mod pfm;
pub mod png;
pub mod rgbe;

use crate::data::Image;

/// A decoding or encoding failure, as a plain message (the caller adds the file name).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct FormatError(pub String);

/// The largest image any reader accepts: 2^28 pixels (16384 x 16384), i.e. up to 3 GiB of f32 RGB.
///
/// Why: a header is a few bytes of untrusted input that decides an allocation; without a cap a
/// 40-byte file could ask for terabytes. 2^28 is far above any environment map in use
/// (the largest common ones are 16k x 8k = 2^27).
pub const MAX_PIXELS: usize = 1 << 28;

/// The extensions [`decode_by_extension`] understands, for messages and help text.
pub const SUPPORTED_EXTENSIONS: &[&str] = &["hdr", "pic", "rgbe", "pfm", "exr"];

/// Decodes `bytes` with the reader chosen by the file extension `ext` (case-insensitive, with or
/// without a leading dot): `hdr`/`pic`/`rgbe` -> Radiance RGBE, `pfm` -> PFM, `exr` -> OpenEXR.
///
/// Dispatch is by extension rather than by sniffing magic bytes so that a mislabelled file fails
/// with the reader's own precise message ("not a Radiance file (bad magic)") instead of silently
/// being read as something else.
pub fn decode_by_extension(bytes: &[u8], ext: &str) -> Result<Image, FormatError> {
    let ext = ext.trim_start_matches('.').to_ascii_lowercase();
    match ext.as_str() {
        "hdr" | "pic" | "rgbe" => self::rgbe::decode(bytes),
        "pfm" => self::pfm::decode(bytes),
        "exr" => self::exr::decode(bytes),
        _ => Err(FormatError(format!(
            "unsupported image extension {:?} (supported: {})",
            ext,
            SUPPORTED_EXTENSIONS.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// The size of the image a file holds, read from its header only (the first 64 KiB; for EXR the
/// header part of the file), or `None` when it cannot be told cheaply. Validation uses it to
/// check that inputs agree in size before anything runs; the decoder remains the authority.
pub fn header_size(path: &std::path::Path) -> Option<(usize, usize)> {
    use std::io::Read;
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    if ext == "exr" {
        let meta = ::exr::meta::MetaData::read_from_file(path, false).ok()?;
        let header = meta.headers.iter().find(|h| !h.deep)?;
        return Some((header.layer_size.0, header.layer_size.1));
    }
    let mut prefix = Vec::with_capacity(1 << 16);
    std::fs::File::open(path).ok()?.take(1 << 16).read_to_end(&mut prefix).ok()?;
    match ext.as_str() {
        "hdr" | "pic" | "rgbe" => self::rgbe::header_size(&prefix).ok(),
        "pfm" => self::pfm::header_size(&prefix).ok(),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatches_by_extension_case_insensitively() {
        let img = Image::from_vec(2, 1, 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let pfm = self::pfm::encode(&img);
        assert_eq!(decode_by_extension(&pfm, "PFM").unwrap(), img);
        assert_eq!(decode_by_extension(&pfm, ".pfm").unwrap(), img);
        let hdr = self::rgbe::encode(&img);
        assert_eq!(decode_by_extension(&hdr, "HDR").unwrap().width, 2);
        assert_eq!(decode_by_extension(&hdr, "pic").unwrap().width, 2);
    }

    #[test]
    fn unknown_extension_lists_supported_ones() {
        let e = decode_by_extension(b"whatever", "jpg").unwrap_err().0;
        assert!(e.contains(".hdr") && e.contains(".pfm") && e.contains(".exr"), "{e}");
    }
}
