//! Image file formats: readers and writers for the HDR formats hdrflow consumes and produces.
//!
//! | module      | format                          | read | write | notes |
//! |-------------|---------------------------------|------|-------|-------|
//! | [`rgbe`]    | Radiance `.hdr` / `.pic` (RGBE)  | yes  | yes   | hand-written, new-style RLE + flat + old `1 1 1 n` |
//! | [`pfm`]     | Portable Float Map `.pfm`        | yes  | yes   | hand-written (the `image` crate has no PFM) |
//! | [`exr`]     | OpenEXR `.exr`                   | yes  | yes   | through the `exr` crate: see its docs for parts, windows, colour, what is refused |
//! | [`ktx2`]    | Khronos KTX 2.0 `.ktx2`          | no   | yes   | RGBA16F/RGBA32F/RGB9E5/B10G11R11/RG16F, 2D or cube, mip levels in one file, optional Zstandard |
//! | [`ktx1`]    | Khronos KTX 1.1 `.ktx`           | no   | yes   | Filament's: R11F_G11F_B10F/RGBA16F cube with mips, the `sh` key |
//! | [`babylon_env`] | Babylon.js `.env`            | no   | yes   | RGBD PNG faces of every level, the irradiance polynomial, `EnvironmentTextureTools` v2 |
//! | [`playcanvas_atlas`] | PlayCanvas `envAtlas` layout | no | yes | 512 x 512: equirect reflection levels and ambient with 1-texel seams, as `EnvLighting.generateAtlas` lays them out |
//! | [`rgbp`]    | RGBP (PlayCanvas)               | no   | yes   | 8-bit HDR packing up to 64, as RGBA PNG (`Save(png_format: Rgbp)`) |
//! | [`packed_float`] | rgb9e5, 11/10-bit floats    | -    | -     | the packed texel encodings and their error bounds |
//! | [`png`]     | PNG (8-bit sRGB preview, 16-bit linear) | no   | yes   | exposure + sRGB OETF, or linear 16-bit, through the `image` crate |
//! | [`photo`]   | photographs: PNG, JPEG, TIFF of 8/16-bit codes with EXIF | yes | yes | `LoadImage`, `LoadBrackets`, saved brackets; `image` codecs, `kamadak-exif` |
//! | [`builtin`] | procedural lat-long maps         | -    | -     | so that everything runs with no data files |
//!
//! [`save`] holds `Save`'s encoders of every built-in value type (images through the writers
//! above, curves through `crate::plotting`, tables through [`csv`] and JSON), registered on a
//! registry beside the types.
//!
//! Every reader returns a [`crate::values::Image`]: f32 samples, row 0 at the top, 1, 3 or 4 (EXR
//! alpha) channels; photographs are the exception: [`photo`] returns their integer codes, which
//! `LoadImage` turns into floats and `LoadBrackets` keeps. [`decode_by_extension_with`] takes
//! [`DecodeOptions`]: the EXR part or layer, the window (display or data), and the colour space
//! (converted to linear Rec. 709 from EXR `chromaticities` or Radiance `PRIMARIES`, or as stored).
//! f32 (not f16) in memory because real suns exceed the half-float maximum of 65504
//! (`../shared/NOTES.md`, "Formats": the park map's sun is 69120).
//!
//! Every reader treats its input as hostile: it never panics, never indexes out of bounds, and
//! refuses a header that claims more than [`MAX_PIXELS`] pixels, or more than the bytes that follow
//! can hold (for RGBE and PFM, whose encodings have a minimum size per pixel; for EXR, whose
//! compression has no useful bound, a chunk offset table that must fit in the file and point
//! inside it), *before* allocating anything proportional to the claimed size.
//! Errors are a plain [`FormatError`] message; the caller adds the file name.

pub mod babylon_env;
pub mod builtin;
pub mod csv;
pub mod exr;
pub mod gltf_ibl;
pub mod ktx1;
pub mod ktx2;
pub mod packed_float;
pub mod pfm;
pub mod photo;
pub mod playcanvas_atlas;
pub mod png;
pub mod rgbd;
pub mod rgbe;
pub mod rgbp;
pub mod save;
pub mod srgb8;
pub mod yca;

use crate::values::Image;

/// A decoding or encoding failure (the caller adds the file name).
///
/// Its text is what a user sees; the variant tells a refused input from a bug. The EXR reader
/// and writer run the `exr` crate under `catch_unwind`, so that a panic inside the dependency
/// reaches the user as an error rather than aborting a run; the fuzz target and the corpus
/// replays in CI (`fuzz/checks.rs`) reject [`FormatError::DecoderPanicked`], since a caught panic
/// is still a bug (in hdrflow's use of the crate or in the crate itself).
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The bytes are not a file the reader accepts, or the image cannot be written: why, in words.
    #[error("{0}")]
    Invalid(String),
    /// The `exr` crate panicked while decoding (the panic's message).
    #[error("exr decoder panicked: {0}")]
    DecoderPanicked(String),
    /// The `exr` crate panicked while encoding (the panic's message).
    #[error("exr encoder panicked: {0}")]
    EncoderPanicked(String),
}

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
    decode_by_extension_with(bytes, ext, &DecodeOptions::default())
}

/// [`decode_by_extension`] with options: `part`, `layer` and `window` concern EXR only;
/// `colorspace` concerns EXR (`chromaticities`) and Radiance (`PRIMARIES=`). PFM has no colour
/// space information and is returned as stored.
pub fn decode_by_extension_with(bytes: &[u8], ext: &str, options: &DecodeOptions) -> Result<Image, FormatError> {
    let ext = ext.trim_start_matches('.').to_ascii_lowercase();
    match ext.as_str() {
        "hdr" | "pic" | "rgbe" => {
            let mut image = self::rgbe::decode(bytes)?;
            if options.colorspace == ColorSpace::Linear709 {
                if let Some(m) = self::rgbe::primaries(bytes).and_then(|p| p.to_rec709()) {
                    apply_matrix(&mut image, &m);
                }
            }
            Ok(image)
        }
        "pfm" => self::pfm::decode(bytes),
        "exr" => self::exr::decode_with(bytes, options),
        _ => Err(FormatError::Invalid(format!(
            "unsupported image extension {:?} (supported: {})",
            ext,
            SUPPORTED_EXTENSIONS.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// The size of the image a file holds, read from its header only (the first 64 KiB; for EXR the
/// header part of the file), or `None` when it cannot be told cheaply. Validation uses it to
/// check that inputs agree in size before anything runs; the decoder remains the authority.
pub fn header_size(path: &std::path::Path, options: &DecodeOptions) -> Option<(usize, usize)> {
    use std::io::Read;
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    if ext == "exr" {
        // The headers only: at most the first 16 MiB (headers are far smaller).
        let mut prefix = Vec::new();
        std::fs::File::open(path).ok()?.take(1 << 24).read_to_end(&mut prefix).ok()?;
        return self::exr::header_size(&prefix, options);
    }
    let mut prefix = Vec::with_capacity(1 << 16);
    std::fs::File::open(path).ok()?.take(1 << 16).read_to_end(&mut prefix).ok()?;
    match ext.as_str() {
        "hdr" | "pic" | "rgbe" => self::rgbe::header_size(&prefix).ok(),
        "pfm" => self::pfm::header_size(&prefix).ok(),
        _ => None,
    }
}

crate::choice! {
    /// Which rectangle of an EXR file becomes the image.
    pub enum Window {
        /// the data window, as stored
        Data,
        /// the display window; pixels outside the data window are 0
        Display,
    }
}

crate::choice! {
    /// What colour space RGB is returned in.
    pub enum ColorSpace {
        /// converted from the file's primaries (EXR `chromaticities`, Radiance `PRIMARIES`) to linear Rec. 709 (no white adaptation, as OpenEXR)
        Linear709,
        /// the values as stored, whatever the file's primaries
        AsStored,
    }
}

/// How a file is decoded (the defaults are [`decode_by_extension`]'s).
#[derive(Clone, Debug, PartialEq)]
pub struct DecodeOptions {
    /// EXR: the part (0-based); `None` = the first part with a colour channel.
    pub part: Option<usize>,
    /// EXR: a part's name or a channel-name prefix (`diffuse` for `diffuse.R`).
    pub layer: Option<String>,
    pub window: Window,
    pub colorspace: ColorSpace,
}

impl Default for DecodeOptions {
    fn default() -> Self {
        DecodeOptions { part: None, layer: None, window: Window::Display, colorspace: ColorSpace::Linear709 }
    }
}

/// CIE 1931 xy chromaticities of three primaries and a white point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primaries {
    pub red: [f64; 2],
    pub green: [f64; 2],
    pub blue: [f64; 2],
    pub white: [f64; 2],
}

type Mat3 = [[f64; 3]; 3];

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn invert(m: &Mat3) -> Option<Mat3> {
    let c = |r: usize, s: usize| {
        m[(r + 1) % 3][(s + 1) % 3] * m[(r + 2) % 3][(s + 2) % 3]
            - m[(r + 1) % 3][(s + 2) % 3] * m[(r + 2) % 3][(s + 1) % 3]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    if !det.is_finite() || det.abs() < 1e-12 {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = c(j, i) / det;
        }
    }
    Some(inv)
}

fn xyz(xy: [f64; 2]) -> [f64; 3] {
    [xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]]
}

impl Primaries {
    /// ITU-R BT.709 primaries, D65 white (OpenEXR's default chromaticities).
    pub const REC709: Primaries =
        Primaries { red: [0.64, 0.33], green: [0.30, 0.60], blue: [0.15, 0.06], white: [0.3127, 0.3290] };

    /// The RGB -> XYZ matrix (Y of white = 1), as OpenEXR's `RGBtoXYZ`; `None` if degenerate.
    pub fn rgb_to_xyz(&self) -> Option<Mat3> {
        let all = [self.red, self.green, self.blue, self.white];
        if all.iter().flatten().any(|v| !v.is_finite()) || self.white[1].abs() < 1e-9 {
            return None;
        }
        // Primaries as x, y, z = 1 - x - y (so a primary with y = 0, like XYZ's Z, is fine),
        // each scaled so that they sum to the white point's XYZ (Y = 1), as OpenEXR does.
        let xyz_of = |p: [f64; 2]| [p[0], p[1], 1.0 - p[0] - p[1]];
        let (r, g, b, w) = (xyz_of(self.red), xyz_of(self.green), xyz_of(self.blue), xyz(self.white));
        let m = [[r[0], g[0], b[0]], [r[1], g[1], b[1]], [r[2], g[2], b[2]]];
        let s = invert(&m)?;
        let scale: Vec<f64> = (0..3).map(|i| (0..3).map(|k| s[i][k] * w[k]).sum()).collect();
        Some([
            [m[0][0] * scale[0], m[0][1] * scale[1], m[0][2] * scale[2]],
            [m[1][0] * scale[0], m[1][1] * scale[1], m[1][2] * scale[2]],
            [m[2][0] * scale[0], m[2][1] * scale[1], m[2][2] * scale[2]],
        ])
    }

    /// Luminance weights (the Y row of [`Self::rgb_to_xyz`]), OpenEXR's `computeYw`; Rec. 709's
    /// when degenerate.
    pub fn luminance_weights(&self) -> [f64; 3] {
        match self.rgb_to_xyz().or_else(|| Primaries::REC709.rgb_to_xyz()) {
            Some(m) => m[1],
            None => crate::colour::REC709,
        }
    }

    /// The matrix from these primaries to linear Rec. 709 / D65: RGB -> XYZ -> Rec. 709 RGB,
    /// **without** chromatic adaptation, as OpenEXR does (`RGBtoXYZ(file) * XYZtoRGB(display)`,
    /// exrdisplay): the OpenEXR test set's `XYZ.exr` (white E in its header) holds the plain XYZ
    /// of `Rec709.exr`'s D65 pixels, and "should look the same" only this way (a Bradford
    /// E -> D65 adaptation makes its mean R 16% low). `None` when the primaries already are
    /// Rec. 709 (within 1e-4) or degenerate.
    pub fn to_rec709(&self) -> Option<Mat3> {
        let same = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-4 && (a[1] - b[1]).abs() < 1e-4;
        let r = Primaries::REC709;
        if same(self.red, r.red) && same(self.green, r.green) && same(self.blue, r.blue) && same(self.white, r.white) {
            return None;
        }
        let src = self.rgb_to_xyz()?;
        let dst = invert(&r.rgb_to_xyz()?)?;
        Some(mul(&dst, &src))
    }
}

/// Multiplies the first three channels of every pixel by `m`.
pub fn apply_matrix(image: &mut Image, m: &Mat3) {
    let c = image.channels;
    if c < 3 {
        return;
    }
    for p in image.data.chunks_exact_mut(c) {
        let (r, g, b) = (p[0] as f64, p[1] as f64, p[2] as f64);
        for k in 0..3 {
            p[k] = (m[k][0] * r + m[k][1] * g + m[k][2] * b) as f32;
        }
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
        let e = decode_by_extension(b"whatever", "jpg").unwrap_err().to_string();
        assert!(e.contains(".hdr") && e.contains(".pfm") && e.contains(".exr"), "{e}");
    }

    #[test]
    fn radiance_primaries_are_converted_unless_as_stored() {
        let img = Image::from_vec(1, 1, 3, vec![0.5, 0.25, 0.125]);
        let plain = self::rgbe::encode(&img);
        let mut with = b"#?RADIANCE\nPRIMARIES= 0.68 0.32 0.265 0.69 0.15 0.06 0.3127 0.3290\n".to_vec();
        with.extend_from_slice(&plain[plain.iter().position(|&b| b == b'\n').unwrap() + 1..]);
        let raw = decode_by_extension(&plain, "hdr").unwrap();
        let stored = decode_by_extension_with(
            &with,
            "hdr",
            &DecodeOptions { colorspace: ColorSpace::AsStored, ..Default::default() },
        )
        .unwrap();
        assert_eq!(stored, raw);
        let converted = decode_by_extension(&with, "hdr").unwrap();
        let p3 = Primaries { red: [0.68, 0.32], green: [0.265, 0.69], blue: [0.15, 0.06], white: [0.3127, 0.3290] };
        let m = p3.to_rec709().unwrap();
        for (row, got) in m.iter().zip(&converted.data) {
            let want: f64 = (0..3).map(|j| row[j] * raw.data[j] as f64).sum();
            assert!((*got as f64 - want).abs() < 1e-6, "{:?}", converted.data);
        }
        assert!(self::rgbe::primaries(&plain).is_none());
    }

    #[test]
    fn primaries_matrices() {
        // Rec. 709 luminance weights.
        let yw = Primaries::REC709.luminance_weights();
        assert!(yw.iter().zip(crate::colour::REC709).all(|(got, want)| (got - want).abs() < 1e-3), "{yw:?}");
        assert!(Primaries::REC709.to_rec709().is_none());
        // XYZ primaries (R=X, G=Y, B=Z, white E), as OpenEXR's XYZ.exr: RGB -> XYZ is the identity.
        let xyzp = Primaries { red: [1.0, 0.0], green: [0.0, 1.0], blue: [0.0, 0.0], white: [1.0 / 3.0, 1.0 / 3.0] };
        let id = xyzp.rgb_to_xyz().unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((id[i][j] - if i == j { 1.0 } else { 0.0 }).abs() < 1e-9, "{id:?}");
            }
        }
        // XYZ of D65 white -> Rec. 709 (1, 1, 1) (no adaptation: XYZ is absolute).
        let m = xyzp.to_rec709().unwrap();
        let d65 = [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];
        for row in m {
            let v: f64 = (0..3).map(|k| row[k] * d65[k]).sum();
            assert!((v - 1.0).abs() < 1e-6, "{v}");
        }
        // Display P3 (D65): its white (1, 1, 1) is Rec. 709 white.
        let p3 = Primaries { red: [0.68, 0.32], green: [0.265, 0.69], blue: [0.15, 0.06], white: [0.3127, 0.3290] };
        let m = p3.to_rec709().unwrap();
        for row in m {
            let v: f64 = row.iter().sum();
            assert!((v - 1.0).abs() < 1e-9, "{v}");
        }
        assert!(m[0][0] > 1.2 && m[0][1] < -0.2, "{m:?}");
    }
}
