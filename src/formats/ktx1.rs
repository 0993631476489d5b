//! Khronos KTX 1.1 (`.ktx`) writer, for Filament (`Engine::createIblFromKtx1`, `Ktx1Bundle`): what
//! its `cmgen` writes, a cube map with its mips (or a 2D texture) in `R11F_G11F_B10F` or `RGBA16F`,
//! and the 3-band irradiance SH as text under the key `sh`.
//!
//! The layout (KTX 1.1 specification, <https://registry.khronos.org/KTX/specs/1.0/ktxspec.v1.html>):
//! the identifier `«KTX 11»\r\n\x1A\n`, the endianness word 0x04030201 (little-endian file),
//! `glType`, `glTypeSize`, `glFormat`, `glInternalFormat`, `glBaseInternalFormat`, `pixelWidth`,
//! `pixelHeight`, `pixelDepth` 0, `numberOfArrayElements` 0, `numberOfFaces` 1 or 6 (+X, -X, +Y, -Y,
//! +Z, -Z), `numberOfMipmapLevels`, `bytesOfKeyValueData`; then the key/value entries (u32
//! `keyAndValueByteSize`, key NUL value, padded to 4 bytes); then per level, largest first, the u32
//! `imageSize` (for a cube map that is not an array: the bytes of ONE face, the specification's
//! exception) and the faces' texels, row 0 first. `cubePadding` and `mipPadding` are always
//! empty, since every face is a whole number of 4-byte words (4 or 8 bytes per texel).
//!
//! The GL fields, as Filament's reader (`libs/ktxreader/src/Ktx1Reader.cpp`) maps them:
//!
//! | format | glType | glTypeSize | glFormat | glInternalFormat | glBaseInternalFormat |
//! |---|---|---|---|---|---|
//! | `Rg11b10f` | 0x8C3A | 4 | 0x1907 `GL_RGB` | 0x8C3A `GL_R11F_G11F_B10F` | 0x1907 `GL_RGB` |
//! | `Rgba16f` | 0x140B `GL_HALF_FLOAT` | 2 | 0x1908 `GL_RGBA` | 0x881A `GL_RGBA16F` | 0x1908 `GL_RGBA` |
//!
//! Where this departs from the KTX 1.1 specification, and why: `glType` of R11F_G11F_B10F should
//! be `GL_UNSIGNED_INT_10F_11F_11F_REV` (0x8C3B), but Filament's `toPixelDataType` knows only
//! 0x8C3A there (cmgen writes the internal format into all four fields) and would reject 0x8C3B.
//! `glFormat` and `glBaseInternalFormat` are the specification's `GL_RGB`, which Filament reads
//! (its reader keeps 0x8C3A in `glFormat` only for cmgen files of Filament 1.8.0 and before), and
//! `glTypeSize` is 4, the size of the packed word (cmgen writes 1; nothing reads it on a
//! little-endian machine).
//!
//! The `sh` value is cmgen's text (`tools/cmgen/src/cmgen.cpp`, `iblRoughnessPrefilter`): per
//! coefficient, in the order l = 0, 1, 2, m = -l..=l (index l(l+1)+m, which is also hdrflow's),
//! `r g b\n` with each float as C++'s `ostream << float` prints it (`%g`: 6 significant digits,
//! trailing zeros dropped), and no terminating NUL (Filament's `setMetadata` stores the C string's
//! characters only). `Ktx1Bundle::getSphericalHarmonics` reads exactly 27 floats with `strtof`.
//! Which coefficients belong there (Filament's pre-scaled irradiance SH, in its frame) is the
//! caller's choice: this module only writes them.

use crate::formats::ktx2::{key_values, KtxFormat, Level};
use crate::formats::FormatError;

crate::choice! {
    /// The texel format of a `.ktx` file: the two that Filament's cmgen writes.
    #[derive(Default)]
    pub enum Ktx1Format {
        /// `GL_R11F_G11F_B10F`: RGB as 11-, 11- and 10-bit unsigned floats, 4 bytes (cmgen's
        /// default); [0, 65024] ([0, 64512] for B), relative error 2^-7 (R, G) and 2^-6 (B).
        #[default]
        Rg11b10f,
        /// `GL_RGBA16F`: half floats, clamped to +-65504.
        Rgba16f,
    }
}

impl Ktx1Format {
    /// The encoding of a texel, shared with the KTX2 writer.
    pub fn texels(self) -> KtxFormat {
        match self {
            Ktx1Format::Rg11b10f => KtxFormat::Rg11b10f,
            Ktx1Format::Rgba16f => KtxFormat::Rgba16f,
        }
    }

    /// `glType`, `glTypeSize`, `glFormat`, `glInternalFormat`, `glBaseInternalFormat` (see the
    /// module's table).
    pub fn gl_fields(self) -> [u32; 5] {
        match self {
            Ktx1Format::Rg11b10f => [0x8C3A, 4, 0x1907, 0x8C3A, 0x1907],
            Ktx1Format::Rgba16f => [0x140B, 2, 0x1908, 0x881A, 0x1908],
        }
    }
}

/// The 12-byte file identifier `«KTX 11»\r\n\x1A\n`.
pub const IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31, 0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

/// Key/value entries to write, in order (`Save` puts the `sh` text here).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KeyValues(pub Vec<(String, Vec<u8>)>);

/// Encodes a texture of `face_count` (1 or 6) faces and the given levels (level 0 first; level k
/// must be max(1, width >> k) x max(1, height >> k)) with the given key/value entries.
pub fn encode(
    levels: &[Level],
    face_count: usize,
    format: Ktx1Format,
    key_value: &KeyValues,
) -> Result<Vec<u8>, FormatError> {
    crate::formats::ktx2::check_levels(levels, face_count, "KTX")?;
    if let Some((key, _)) = key_value.0.iter().find(|(k, _)| k.is_empty() || k.contains('\0')) {
        return Err(FormatError::Invalid(format!("a KTX key must be non-empty text without NUL, not {key:?}")));
    }
    let entries: Vec<(&str, &[u8])> = key_value.0.iter().map(|(k, v)| (k.as_str(), v.as_slice())).collect();
    let kvd = key_values(&entries);
    let texels = format.texels();
    let (w0, h0) = (levels[0].width as u32, levels[0].height as u32);
    let mut out = Vec::with_capacity(64 + kvd.len() + levels.iter().map(|l| 4 + l.rgba.len() / 4 * 8).sum::<usize>());
    out.extend_from_slice(&IDENTIFIER);
    out.extend_from_slice(&0x0403_0201u32.to_le_bytes());
    let [gl_type, type_size, gl_format, internal, base] = format.gl_fields();
    let n = levels.len() as u32;
    for v in [gl_type, type_size, gl_format, internal, base, w0, h0, 0, 0, face_count as u32, n, kvd.len() as u32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    debug_assert_eq!(out.len(), 64);
    out.extend_from_slice(&kvd);
    for level in levels {
        let bytes = texels.encode_texels(level.rgba);
        // A cube map that is not an array gives the size of one face; anything else the level's.
        let image_size = if face_count == 6 { bytes.len() / 6 } else { bytes.len() };
        let image_size = u32::try_from(image_size)
            .map_err(|_| FormatError::Invalid(format!("a {image_size}-byte image is too large for KTX")))?;
        out.extend_from_slice(&image_size.to_le_bytes());
        out.extend_from_slice(&bytes);
    }
    Ok(out)
}

/// cmgen's `sh` text for the 9 RGB coefficients of 3 bands (see the module docs); an error for
/// another count or a value that is not finite.
pub fn sh_text(coefficients: &[[f64; 3]]) -> Result<String, FormatError> {
    if coefficients.len() != 9 {
        return Err(FormatError::Invalid(format!(
            "Filament reads 3 bands (9 RGB coefficients) from the KTX key sh, but {} were given",
            coefficients.len()
        )));
    }
    let mut text = String::new();
    for (i, rgb) in coefficients.iter().enumerate() {
        // Stored as float by cmgen, then printed.
        let rgb = rgb.map(|v| v as f32);
        if let Some(v) = rgb.iter().find(|v| !v.is_finite()) {
            return Err(FormatError::Invalid(format!("SH coefficient {i} is {v}, which Filament cannot use")));
        }
        let [r, g, b] = rgb.map(|v| cpp_float(v as f64));
        text.push_str(&format!("{r} {g} {b}\n"));
    }
    Ok(text)
}

/// A finite number as C++'s default `ostream <<` prints it: `%g` with 6 significant digits,
/// fixed notation when the decimal exponent is in [-4, 6), else `1.5e-07`; trailing zeros (and a
/// trailing point) dropped.
pub fn cpp_float(v: f64) -> String {
    const DIGITS: i32 = 6;
    if v == 0.0 {
        return if v.is_sign_negative() { "-0" } else { "0" }.into();
    }
    let strip = |s: String| if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
    // The exponent after rounding to 6 significant digits, as printf decides.
    let scientific = format!("{:.*e}", (DIGITS - 1) as usize, v);
    let (mantissa, exponent) = scientific.split_once('e').unwrap_or((&scientific, "0"));
    let exponent: i32 = exponent.parse().unwrap_or(0);
    if (-4..DIGITS).contains(&exponent) {
        strip(format!("{:.*}", (DIGITS - 1 - exponent) as usize, v))
    } else {
        let sign = if exponent < 0 { '-' } else { '+' };
        format!("{}e{sign}{:02}", strip(mantissa.to_string()), exponent.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_print_as_cpp_ostream_does() {
        // What `std::cout << x` prints for these floats (glibc, default precision 6).
        let cases: [(f32, &str); 12] = [
            (1.0, "1"),
            (0.5, "0.5"),
            (-0.25, "-0.25"),
            (1.234_567_9, "1.23457"),
            (123456.0, "123456"),
            (1234567.0, "1.23457e+06"),
            (0.0001, "0.0001"),
            (0.00001, "1e-05"),
            (0.000123456, "0.000123456"),
            (999999.5, "1e+06"),
            (1.0e-20, "1e-20"),
            (0.1, "0.1"),
        ];
        for (v, want) in cases {
            assert_eq!(cpp_float(v as f64), want, "{v}");
        }
        assert_eq!(cpp_float(-0.0), "-0");
        assert_eq!(cpp_float(0.0), "0");
    }

    #[test]
    fn sh_text_is_nine_lines_and_refuses_other_counts_and_nan() {
        let sh: Vec<[f64; 3]> = (0..9).map(|i| [i as f64, 0.5 * i as f64, -0.125]).collect();
        let text = sh_text(&sh).unwrap();
        assert_eq!(text.lines().count(), 9);
        assert!(text.starts_with("0 0 -0.125\n1 0.5 -0.125\n") && text.ends_with("8 4 -0.125\n"), "{text}");
        let e = sh_text(&sh[..4]).unwrap_err().to_string();
        assert_eq!(e, "Filament reads 3 bands (9 RGB coefficients) from the KTX key sh, but 4 were given");
        let mut bad = sh.clone();
        bad[3][1] = f64::NAN;
        assert_eq!(sh_text(&bad).unwrap_err().to_string(), "SH coefficient 3 is NaN, which Filament cannot use");
    }

    #[test]
    fn refuses_bad_keys_and_levels() {
        let rgba = [1.0f32; 4 * 6];
        let level = [Level { width: 1, height: 1, rgba: &rgba }];
        let bad = KeyValues(vec![(String::new(), b"x".to_vec())]);
        let e = encode(&level, 6, Ktx1Format::Rg11b10f, &bad).unwrap_err().to_string();
        assert_eq!(e, "a KTX key must be non-empty text without NUL, not \"\"");
        let e = encode(&level, 3, Ktx1Format::Rg11b10f, &KeyValues::default()).unwrap_err().to_string();
        assert_eq!(e, "a KTX texture has 1 or 6 faces, not 3");
        let empty = [Level { width: 0, height: 0, rgba: &[] }];
        let e = encode(&empty, 1, Ktx1Format::Rg11b10f, &KeyValues::default()).unwrap_err().to_string();
        assert_eq!(e, "a 0x0 image cannot be written as KTX");
        let e = encode(&[], 1, Ktx1Format::Rg11b10f, &KeyValues::default()).unwrap_err().to_string();
        assert_eq!(e, "no levels to write");
        let rgba2 = [1.0f32; 4 * 6 * 4];
        let levels = [Level { width: 2, height: 2, rgba: &rgba2 }, Level { width: 2, height: 2, rgba: &rgba2 }];
        let e = encode(&levels, 6, Ktx1Format::Rgba16f, &KeyValues::default()).unwrap_err().to_string();
        assert_eq!(e, "KTX level 1 must be 1x1 (max(1, base >> 1)), but it is 2x2");
    }
}
