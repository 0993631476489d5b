//! Khronos KTX 2.0 (`.ktx2`) writer: uncompressed float textures, 2D or cube, with mips, optionally
//! Zstandard-supercompressed.
//!
//! What is written (KTX 2.0 specification, <https://registry.khronos.org/KTX/specs/2.0/ktxspec.v2.html>):
//!
//! - `vkFormat` ([`KtxFormat`]): `VK_FORMAT_R16G16B16A16_SFLOAT` (97, typeSize 2),
//!   `VK_FORMAT_R32G32B32A32_SFLOAT` (109, typeSize 4), `VK_FORMAT_E5B9G9R9_UFLOAT_PACK32` (123) and
//!   `VK_FORMAT_B10G11R11_UFLOAT_PACK32` (122), both typeSize 4 (a `_PACK32`'s), or
//!   `VK_FORMAT_R16G16_SFLOAT` (83, typeSize 2); `pixelDepth` 0, `layerCount` 0, `faceCount` 1 or 6
//!   (+X, -X, +Y, -Y, +Z, -Z), `levelCount` = the number of levels given.
//! - `supercompressionScheme` 0 (none) or 2 (Zstandard, [`KtxSupercompression::Zstd`]): then each
//!   level is compressed on its own (one zstd frame), `byteLength` is the compressed size,
//!   `uncompressedByteLength` the level's texel bytes, and there is no global data
//!   (`sgdByteOffset` = `sgdByteLength` = 0), as the specification says for Zstandard.
//! - The level index lists level 0 first; the level data are laid out from the smallest level to
//!   the largest (the specification's order). Uncompressed, each level's `byteOffset` is aligned to
//!   lcm(texel block size, 4) = 8 (RGBA16F), 16 (RGBA32F) or 4 (the 4-byte formats) bytes and
//!   `uncompressedByteLength` = `byteLength`; supercompressed, the alignment is 1 and the levels
//!   follow one another without padding (what `ktx validate` expects). Within a level: face by
//!   face, row by row, row 0 first.
//! - One basic Data Format Descriptor block, as Khronos' own generator writes for the format
//!   ([`dfd`]; the tests compare ours with the `ktx2` crate's generator).
//! - Key/value data, sorted by key: `KTXorientation` = `rd` (x to the right, y down: row 0 is the
//!   top row, which is how hdrflow stores images and cube faces; for a cube map this is the
//!   OpenGL/Vulkan face layout, row 0 at t = 0) and `KTXwriter` = `hdrflow <version>`.
//!
//! Values: the encoder takes RGBA (RGB gets alpha 1, one channel is replicated to RGB); a format
//! without alpha (or B) drops it. f16 has a largest finite value of 65504: larger values (a real
//! sun: 69120 in the park map) are clamped to 65504 rather than written as infinity, which would
//! poison any filtering; use `Rgba32f` to keep them. NaN is written as NaN in `Rgba16f` (as before
//! the other formats existed), as 0 in `Rg16f`, `Rgb9e5` and `Rg11b10f`, whose negatives also become
//! 0 and whose values above their maximum become the maximum ([`super::packed_float`] has the
//! encodings and their error bounds). [`KtxFormat::clamps`] tells which texels change beyond
//! rounding, so that `Save` warns once with their count.

pub mod dfd;

use rayon::prelude::*;

use crate::formats::packed_float::{self, RGB9E5_MAX, UF10_MAX, UF11_MAX};
use crate::formats::FormatError;
use ::exr::prelude::f16;

crate::choice! {
    /// The texel format of a `.ktx2` file (and of a `.ktx` file's texels).
    pub enum KtxFormat {
        /// `VK_FORMAT_R16G16B16A16_SFLOAT` (97): half floats, clamped to +-65504.
        Rgba16f,
        /// `VK_FORMAT_R32G32B32A32_SFLOAT` (109): the f32 values unchanged.
        Rgba32f,
        /// `VK_FORMAT_E5B9G9R9_UFLOAT_PACK32` (123): RGB, a shared exponent, 4 bytes; [0, 65408],
        /// each channel within 2^-9 of the largest (Bevy's environment maps).
        Rgb9e5,
        /// `VK_FORMAT_B10G11R11_UFLOAT_PACK32` (122): RGB as 11-, 11- and 10-bit unsigned floats,
        /// 4 bytes; [0, 65024] ([0, 64512] for B), relative error 2^-7 (R, G) and 2^-6 (B).
        Rg11b10f,
        /// `VK_FORMAT_R16G16_SFLOAT` (83): R and G as half floats (a BRDF LUT), clamped to +-65504.
        Rg16f,
    }
}

/// What `Save` writes unless told otherwise (and an encoder given no format).
impl Default for KtxFormat {
    fn default() -> Self {
        KtxFormat::Rgba16f
    }
}

/// The largest finite half float.
const F16_MAX: f32 = 65504.0;

impl KtxFormat {
    /// The Vulkan format number written in the header.
    pub fn vk_format(self) -> u32 {
        match self {
            KtxFormat::Rgba16f => 97,
            KtxFormat::Rgba32f => 109,
            KtxFormat::Rgb9e5 => 123,
            KtxFormat::Rg11b10f => 122,
            KtxFormat::Rg16f => 83,
        }
    }
    /// The header's typeSize: bytes per channel, or of the packed word for `_PACK32` formats.
    pub fn type_size(self) -> usize {
        match self {
            KtxFormat::Rgba16f | KtxFormat::Rg16f => 2,
            KtxFormat::Rgba32f | KtxFormat::Rgb9e5 | KtxFormat::Rg11b10f => 4,
        }
    }
    /// Bytes per texel (the texel block size).
    pub fn texel_bytes(self) -> usize {
        match self {
            KtxFormat::Rgba16f => 8,
            KtxFormat::Rgba32f => 16,
            KtxFormat::Rgb9e5 | KtxFormat::Rg11b10f | KtxFormat::Rg16f => 4,
        }
    }
    /// The channels a texel holds, for messages: `RGBA`, `RGB` or `RG`.
    pub fn channels(self) -> &'static str {
        match self {
            KtxFormat::Rgba16f | KtxFormat::Rgba32f => "RGBA",
            KtxFormat::Rgb9e5 | KtxFormat::Rg11b10f => "RGB",
            KtxFormat::Rg16f => "RG",
        }
    }
    /// What the encoder does to values outside the format's range, for a warning.
    pub fn clamp_note(self) -> &'static str {
        match self {
            KtxFormat::Rgba16f => "beyond +-65504 are clamped to it",
            KtxFormat::Rgba32f => "are kept",
            KtxFormat::Rgb9e5 => "outside [0, 65408] are clamped to it (NaN to 0)",
            KtxFormat::Rg11b10f => "outside [0, 65024] ([0, 64512] for B) are clamped to it (NaN to 0)",
            KtxFormat::Rg16f => "beyond +-65504 are clamped to it (NaN to 0)",
        }
    }

    /// Whether encoding the RGBA texel changes it beyond rounding: a value clamped to the range
    /// (or NaN replaced), in the channels the format keeps. `Rgba16f` counts only magnitudes
    /// beyond 65504 (its NaN is kept).
    pub fn clamps(self, rgba: [f32; 4]) -> bool {
        let signed = |v: f32| v.is_nan() || v.abs() > F16_MAX;
        let unsigned = |v: f32, max: f32| !(0.0..=max).contains(&v);
        match self {
            KtxFormat::Rgba16f => rgba.iter().any(|v| v.abs() > F16_MAX),
            KtxFormat::Rgba32f => false,
            KtxFormat::Rg16f => signed(rgba[0]) || signed(rgba[1]),
            KtxFormat::Rgb9e5 => rgba[..3].iter().any(|&v| unsigned(v, RGB9E5_MAX)),
            KtxFormat::Rg11b10f => {
                unsigned(rgba[0], UF11_MAX) || unsigned(rgba[1], UF11_MAX) || unsigned(rgba[2], UF10_MAX)
            }
        }
    }

    /// Appends the texel's bytes (little-endian).
    pub fn encode_texel(self, rgba: [f32; 4], out: &mut Vec<u8>) {
        let half = |v: f32, nan: f32| f16::from_f32(if v.is_nan() { nan } else { v.clamp(-F16_MAX, F16_MAX) });
        match self {
            KtxFormat::Rgba16f => rgba.iter().for_each(|&v| out.extend_from_slice(&half(v, v).to_le_bytes())),
            KtxFormat::Rgba32f => rgba.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes())),
            KtxFormat::Rg16f => rgba[..2].iter().for_each(|&v| out.extend_from_slice(&half(v, 0.0).to_le_bytes())),
            KtxFormat::Rgb9e5 => {
                out.extend_from_slice(&packed_float::encode_rgb9e5([rgba[0], rgba[1], rgba[2]]).to_le_bytes())
            }
            KtxFormat::Rg11b10f => {
                out.extend_from_slice(&packed_float::encode_b10g11r11([rgba[0], rgba[1], rgba[2]]).to_le_bytes())
            }
        }
    }

    /// The texels' bytes, `rgba` holding four values per texel.
    pub fn encode_texels(self, rgba: &[f32]) -> Vec<u8> {
        let mut out = Vec::with_capacity(rgba.len() / 4 * self.texel_bytes());
        for t in rgba.chunks_exact(4) {
            self.encode_texel([t[0], t[1], t[2], t[3]], &mut out);
        }
        out
    }

    /// Appends the texels of `values` (`channels` 4: RGBA; 3: RGB, alpha 1) to `out`, in parallel
    /// blocks written in place (a 4096 cube's level 0 is 100 M texels: no second copy of it).
    pub fn encode_texels_into(self, values: &[f32], channels: usize, out: &mut Vec<u8>) {
        const BLOCK: usize = 1 << 16;
        let (start, bytes) = (out.len(), self.texel_bytes());
        let texels = values.len() / channels;
        out.resize(start + texels * bytes, 0);
        out[start..].par_chunks_mut(BLOCK * bytes).zip(values.par_chunks(BLOCK * channels)).for_each(|(dst, src)| {
            let mut block = Vec::with_capacity(dst.len());
            for t in src.chunks_exact(channels) {
                let alpha = if channels == 4 { t[3] } else { 1.0 };
                self.encode_texel([t[0], t[1], t[2], alpha], &mut block);
            }
            dst.copy_from_slice(&block);
        });
    }
}

crate::choice! {
    /// The supercompression of a `.ktx2` file's levels.
    #[derive(Default)]
    pub enum KtxSupercompression {
        /// none (supercompressionScheme 0): the texels as they are
        #[default]
        None,
        /// Zstandard (supercompressionScheme 2), each level compressed on its own, at `zstd_level`
        Zstd,
    }
}

/// The Zstandard level `Save` uses unless told otherwise: zstd's own default (`docs/src/benchmarks/ibl.md` has
/// the sizes and times of levels 3, 9 and 19).
pub const DEFAULT_ZSTD_LEVEL: i32 = 3;

/// How the levels are stored: the supercompression and, for Zstandard, its level (1 to 22).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compression {
    pub scheme: KtxSupercompression,
    pub zstd_level: i32,
}

impl Default for Compression {
    fn default() -> Self {
        Compression { scheme: KtxSupercompression::None, zstd_level: DEFAULT_ZSTD_LEVEL }
    }
}

/// The 12-byte file identifier `«KTX 20»\r\n\x1A\n`.
pub const IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

/// One mip level: `faces` images of `size.0 x size.1` RGBA texels, face by face, row by row
/// (`rgba.len() == faces * w * h * 4`).
pub struct Level<'a> {
    pub width: usize,
    pub height: usize,
    pub rgba: &'a [f32],
}

/// One mip level given as RGB (alpha 1): `rgb.len() == faces * w * h * 3` (a cube map's levels as
/// they are held, written without an RGBA copy).
pub struct RgbLevel<'a> {
    pub width: usize,
    pub height: usize,
    pub rgb: &'a [f32],
}

/// Checks a texture of `face_count` (1 or 6) faces and the given levels (level 0 first; level k
/// must be max(1, width >> k) x max(1, height >> k)); `what` names the container in messages.
pub fn check_levels(levels: &[Level], face_count: usize, what: &str) -> Result<(), FormatError> {
    let data: Vec<(usize, usize, usize)> = levels.iter().map(|l| (l.width, l.height, l.rgba.len())).collect();
    check_dims(&data, 4, face_count, what)
}

/// [`check_levels`] on (width, height, value count) per level, `channels` values a texel.
fn check_dims(
    levels: &[(usize, usize, usize)],
    channels: usize,
    face_count: usize,
    what: &str,
) -> Result<(), FormatError> {
    let err = |m: String| Err(FormatError::Invalid(m));
    if face_count != 1 && face_count != 6 {
        return err(format!("a {what} texture has 1 or 6 faces, not {face_count}"));
    }
    let Some(&(w0, h0, _)) = levels.first() else { return err("no levels to write".into()) };
    if w0 == 0 || h0 == 0 || w0 > u32::MAX as usize || h0 > u32::MAX as usize {
        return err(format!("a {w0}x{h0} image cannot be written as {what}"));
    }
    if face_count == 6 && w0 != h0 {
        return err(format!("cube faces must be square, not {w0}x{h0}"));
    }
    let max_levels = 1 + (w0.max(h0) as f64).log2().floor() as usize;
    if levels.len() > max_levels {
        return err(format!("{} levels is more than a {w0}x{h0} base allows ({max_levels})", levels.len()));
    }
    for (k, &(lw, lh, len)) in levels.iter().enumerate() {
        let (w, h) = ((w0 >> k).max(1), (h0 >> k).max(1));
        if (lw, lh) != (w, h) {
            return err(format!("{what} level {k} must be {w}x{h} (max(1, base >> {k})), but it is {lw}x{lh}"));
        }
        if len != face_count * w * h * channels {
            return err(format!("level {k} holds {len} values, not {}", face_count * w * h * channels));
        }
    }
    Ok(())
}

/// Encodes a texture, uncompressed (see [`encode_with`]).
pub fn encode(levels: &[Level], face_count: usize, format: KtxFormat) -> Result<Vec<u8>, FormatError> {
    encode_with(levels, face_count, format, Compression::default())
}

/// Encodes a texture of `face_count` (1 or 6) faces and the given levels (level 0 first; level k
/// must be max(1, width >> k) x max(1, height >> k)), its levels stored as `compression` says.
pub fn encode_with(
    levels: &[Level],
    face_count: usize,
    format: KtxFormat,
    compression: Compression,
) -> Result<Vec<u8>, FormatError> {
    let values: Vec<_> = levels.iter().map(|l| (l.width, l.height, l.rgba)).collect();
    encode_values(&values, 4, face_count, format, compression)
}

/// [`encode_with`] for levels held as RGB (alpha 1), each encoded straight from its RGB values.
pub fn encode_rgb_with(
    levels: &[RgbLevel],
    face_count: usize,
    format: KtxFormat,
    compression: Compression,
) -> Result<Vec<u8>, FormatError> {
    let values: Vec<_> = levels.iter().map(|l| (l.width, l.height, l.rgb)).collect();
    encode_values(&values, 3, face_count, format, compression)
}

/// Levels as (width, height, values), `channels` values a texel (4: RGBA, 3: RGB, alpha 1).
fn encode_values(
    levels: &[(usize, usize, &[f32])],
    channels: usize,
    face_count: usize,
    format: KtxFormat,
    compression: Compression,
) -> Result<Vec<u8>, FormatError> {
    let dims: Vec<(usize, usize, usize)> = levels.iter().map(|&(w, h, v)| (w, h, v.len())).collect();
    check_dims(&dims, channels, face_count, "KTX2")?;
    encode_core(&dims, face_count, format, compression, |k, out| format.encode_texels_into(levels[k].2, channels, out))
}

/// The file around checked levels: `write_level(k, out)` appends level k's texels to `out`. The
/// levels are stored smallest first, each written in place at the end of the file as it grows
/// (compressed ones through one level's buffer), so the file is the only copy of the texels.
fn encode_core(
    levels: &[(usize, usize, usize)],
    face_count: usize,
    format: KtxFormat,
    compression: Compression,
    write_level: impl Fn(usize, &mut Vec<u8>),
) -> Result<Vec<u8>, FormatError> {
    let zstd = compression.scheme == KtxSupercompression::Zstd;
    if zstd && !(1..=22).contains(&compression.zstd_level) {
        return Err(FormatError::Invalid(format!("zstd level {} is out of range (1 to 22)", compression.zstd_level)));
    }
    let (w0, h0, _) = levels[0];
    let n = levels.len();
    // lcm(texel block size, 4) uncompressed: 8, 16 or 4; 1 when supercompressed.
    let align = if zstd { 1 } else { format.texel_bytes() };
    let index_end = 80 + 24 * n;

    let dfd = dfd::basic_dfd(format);
    let dfd_offset = index_end;
    let kvd_offset = dfd_offset + dfd.len();
    let kvd = key_values(&[
        ("KTXorientation", b"rd\0".as_slice()),
        ("KTXwriter", format!("hdrflow {}\0", env!("CARGO_PKG_VERSION")).as_bytes()),
    ]);
    let raw_bytes = |k: usize| {
        let (w, h) = ((w0 >> k).max(1), (h0 >> k).max(1));
        face_count * w * h * format.texel_bytes()
    };
    let texel_total: usize = (0..n).map(|k| raw_bytes(k) + align).sum();
    let mut out = Vec::with_capacity(kvd_offset + kvd.len() + if zstd { 0 } else { texel_total });
    out.extend_from_slice(&IDENTIFIER);
    for v in [format.vk_format(), format.type_size() as u32, w0 as u32, h0 as u32, 0, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let scheme = if zstd { 2 } else { 0 };
    for v in
        [face_count as u32, n as u32, scheme, dfd_offset as u32, dfd.len() as u32, kvd_offset as u32, kvd.len() as u32]
    {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength
    debug_assert_eq!(out.len(), 80);
    out.resize(index_end, 0); // the level index, filled in below
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);

    let mut index = vec![(0u64, 0u64, 0u64); n];
    for k in (0..n).rev() {
        out.resize(out.len().next_multiple_of(align), 0);
        let offset = out.len();
        if zstd {
            let mut raw = Vec::with_capacity(raw_bytes(k));
            write_level(k, &mut raw);
            let packed = zstd::bulk::compress(&raw, compression.zstd_level)
                .map_err(|e| FormatError::Invalid(format!("zstd compression failed: {e}")))?;
            index[k] = (offset as u64, packed.len() as u64, raw.len() as u64);
            out.extend_from_slice(&packed);
        } else {
            write_level(k, &mut out);
            let len = (out.len() - offset) as u64;
            index[k] = (offset as u64, len, len);
        }
    }
    for (k, (offset, length, uncompressed)) in index.into_iter().enumerate() {
        let at = 80 + 24 * k;
        out[at..at + 8].copy_from_slice(&offset.to_le_bytes());
        out[at + 8..at + 16].copy_from_slice(&length.to_le_bytes());
        out[at + 16..at + 24].copy_from_slice(&uncompressed.to_le_bytes());
    }
    Ok(out)
}

/// Key/value data: per entry its byte length, key NUL value, padded to 4 bytes (the padding of the
/// last entry included in the total, as the specification asks).
pub(crate) fn key_values(entries: &[(&str, &[u8])]) -> Vec<u8> {
    let mut out = Vec::new();
    for (key, value) in entries {
        let len = key.len() + 1 + value.len();
        out.extend_from_slice(&(len as u32).to_le_bytes());
        out.extend_from_slice(key.as_bytes());
        out.push(0);
        out.extend_from_slice(value);
        out.resize(out.len().next_multiple_of(4), 0);
    }
    out
}

/// The RGBA values of an image's pixels: [`Image::rgb`](crate::values::Image::rgb) and the
/// channel named `A` (alpha 1 without one).
pub fn image_rgba(img: &crate::values::Image) -> Vec<f32> {
    let alpha = img.alpha_index();
    let mut out = Vec::with_capacity(img.pixel_count() * 4);
    for y in 0..img.height {
        for x in 0..img.width {
            out.extend_from_slice(&img.rgb(x, y));
            out.push(alpha.map_or(1.0, |a| img.pixel(x, y)[a]));
        }
    }
    out
}

/// The RGBA values (alpha 1) of RGB texels.
pub fn rgb_to_rgba(rgb: &[f32]) -> Vec<f32> {
    rgb.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 1.0]).collect()
}

#[cfg(test)]
mod tests;
