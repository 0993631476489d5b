//! Khronos KTX 2.0 (`.ktx2`) writer: uncompressed RGBA float textures, 2D or cube, with mips.
//!
//! What is written (KTX 2.0 specification, <https://registry.khronos.org/KTX/specs/2.0/ktxspec.v2.html>):
//!
//! - `vkFormat` `VK_FORMAT_R16G16B16A16_SFLOAT` (97, typeSize 2) or `VK_FORMAT_R32G32B32A32_SFLOAT`
//!   (109, typeSize 4); `pixelDepth` 0, `layerCount` 0, `faceCount` 1 or 6 (+X, -X, +Y, -Y, +Z, -Z),
//!   `levelCount` = the number of levels given, `supercompressionScheme` 0 (none).
//! - The level index lists level 0 first; the level data are laid out from the smallest level to
//!   the largest (the specification's order), each level's `byteOffset` aligned to
//!   lcm(texel block size, 4) = 8 (RGBA16F) or 16 (RGBA32F) bytes, `uncompressedByteLength` =
//!   `byteLength`. Within a level: face by face, row by row, row 0 first.
//! - One basic Data Format Descriptor block (version 2): `KHR_DF_MODEL_RGBSDA`, BT.709 primaries,
//!   linear transfer, straight alpha, a 1x1x1x1 texel block of 8 or 16 bytes, and four samples
//!   R, G, B, A (channel ids 0, 1, 2, 15) at bit offsets 0, 16, 32, 48 (or 0, 32, 64, 96), each
//!   qualified float and signed, with `sampleLower` -1.0f and `sampleUpper` 1.0f (0xBF800000,
//!   0x3F800000), as Khronos' own DFD generator writes for `*_SFLOAT` formats (the tests compare
//!   ours with the `ktx2` crate's generator, byte for byte).
//! - Key/value data, sorted by key: `KTXorientation` = `rd` (x to the right, y down: row 0 is the
//!   top row, which is how hdrflow stores images and cube faces; for a cube map this is the
//!   OpenGL/Vulkan face layout, row 0 at t = 0) and `KTXwriter` = `hdrflow <version>`.
//!
//! Values: RGB gets alpha 1, one channel is replicated to RGB (alpha 1). f16 has a largest finite
//! value of 65504: larger values (a real sun: 69120 in the park map) are clamped to 65504 rather
//! than written as infinity, which would poison any filtering; use `Rgba32f` to keep them. NaN is
//! written as NaN.

use crate::formats::FormatError;
use ::exr::prelude::f16;

crate::choice! {
    /// The texel format of a `.ktx2` file.
    pub enum KtxFormat {
        /// `VK_FORMAT_R16G16B16A16_SFLOAT` (97): half floats, clamped to +-65504.
        Rgba16f,
        /// `VK_FORMAT_R32G32B32A32_SFLOAT` (109): the f32 values unchanged.
        Rgba32f,
    }
}

/// What `Save` writes unless told otherwise (and an encoder given no format).
impl Default for KtxFormat {
    fn default() -> Self {
        KtxFormat::Rgba16f
    }
}

impl KtxFormat {
    /// The Vulkan format number written in the header.
    pub fn vk_format(self) -> u32 {
        match self {
            KtxFormat::Rgba16f => 97,
            KtxFormat::Rgba32f => 109,
        }
    }
    /// Bytes per channel (the header's typeSize).
    pub fn type_size(self) -> usize {
        match self {
            KtxFormat::Rgba16f => 2,
            KtxFormat::Rgba32f => 4,
        }
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

/// Encodes a texture of `face_count` (1 or 6) faces and the given levels (level 0 first; level k
/// must be max(1, width >> k) x max(1, height >> k)).
pub fn encode(levels: &[Level], face_count: usize, format: KtxFormat) -> Result<Vec<u8>, FormatError> {
    let err = |m: String| Err(FormatError::Invalid(m));
    if face_count != 1 && face_count != 6 {
        return err(format!("a KTX2 texture has 1 or 6 faces, not {face_count}"));
    }
    let Some(base) = levels.first() else { return err("no levels to write".into()) };
    let (w0, h0) = (base.width, base.height);
    if w0 == 0 || h0 == 0 || w0 > u32::MAX as usize || h0 > u32::MAX as usize {
        return err(format!("a {w0}x{h0} image cannot be written as KTX2"));
    }
    if face_count == 6 && w0 != h0 {
        return err(format!("cube faces must be square, not {w0}x{h0}"));
    }
    let max_levels = 1 + (w0.max(h0) as f64).log2().floor() as usize;
    if levels.len() > max_levels {
        return err(format!("{} levels is more than a {w0}x{h0} base allows ({max_levels})", levels.len()));
    }
    for (k, l) in levels.iter().enumerate() {
        let (w, h) = ((w0 >> k).max(1), (h0 >> k).max(1));
        if (l.width, l.height) != (w, h) {
            return err(format!(
                "KTX2 level {k} must be {w}x{h} (max(1, base >> {k})), but it is {}x{}",
                l.width, l.height
            ));
        }
        if l.rgba.len() != face_count * w * h * 4 {
            return err(format!("level {k} holds {} values, not {}", l.rgba.len(), face_count * w * h * 4));
        }
    }

    let n = levels.len();
    let ts = format.type_size();
    let texel = 4 * ts;
    let align = texel; // lcm(texel block size, 4): 8 or 16.
    let index_end = 80 + 24 * n;

    let dfd = basic_dfd(format);
    let dfd_offset = index_end;
    let kvd_offset = dfd_offset + dfd.len();
    let kvd = key_values(&[
        ("KTXorientation", b"rd\0".as_slice()),
        ("KTXwriter", format!("hdrflow {}\0", env!("CARGO_PKG_VERSION")).as_bytes()),
    ]);
    let mut out =
        Vec::with_capacity(kvd_offset + kvd.len() + levels.iter().map(|l| l.rgba.len() * ts + align).sum::<usize>());
    out.extend_from_slice(&IDENTIFIER);
    for v in [format.vk_format(), ts as u32, w0 as u32, h0 as u32, 0, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [face_count as u32, n as u32, 0, dfd_offset as u32, dfd.len() as u32, kvd_offset as u32, kvd.len() as u32]
    {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength
    debug_assert_eq!(out.len(), 80);
    out.resize(index_end, 0); // the level index, filled in below
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);

    let mut index = vec![(0u64, 0u64); n];
    for k in (0..n).rev() {
        out.resize(out.len().next_multiple_of(align), 0);
        let start = out.len();
        match format {
            KtxFormat::Rgba16f => {
                for &v in levels[k].rgba {
                    let v = if v.is_nan() { v } else { v.clamp(-65504.0, 65504.0) };
                    out.extend_from_slice(&f16::from_f32(v).to_le_bytes());
                }
            }
            KtxFormat::Rgba32f => {
                for &v in levels[k].rgba {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        index[k] = (start as u64, (out.len() - start) as u64);
    }
    for (k, (offset, length)) in index.into_iter().enumerate() {
        let at = 80 + 24 * k;
        out[at..at + 8].copy_from_slice(&offset.to_le_bytes());
        out[at + 8..at + 16].copy_from_slice(&length.to_le_bytes());
        out[at + 16..at + 24].copy_from_slice(&length.to_le_bytes());
    }
    Ok(out)
}

/// The DFD section: its total size, then one basic descriptor block with four float samples.
fn basic_dfd(format: KtxFormat) -> Vec<u8> {
    let bits = 8 * format.type_size() as u32;
    let block_size = 24 + 16 * 4;
    let mut d = Vec::with_capacity(4 + block_size);
    let u32s = |d: &mut Vec<u8>, vs: &[u32]| vs.iter().for_each(|v| d.extend_from_slice(&v.to_le_bytes()));
    u32s(&mut d, &[(4 + block_size) as u32]); // dfdTotalSize
                                              // vendorId 0 (Khronos, 17 bits) | descriptorType 0 (basic, 15 bits); versionNumber 2 | blockSize.
    u32s(&mut d, &[0, 2 | ((block_size as u32) << 16)]);
    // colorModel RGBSDA (1), colorPrimaries BT709 (1), transferFunction linear (1), flags 0 (straight alpha).
    d.extend_from_slice(&[1, 1, 1, 0]);
    d.extend_from_slice(&[0, 0, 0, 0]); // texelBlockDimension 0..3, each stored minus 1: 1x1x1x1
    d.extend_from_slice(&[4 * format.type_size() as u8, 0, 0, 0, 0, 0, 0, 0]); // bytesPlane0..7
                                                                               // Qualifiers (the top 4 bits of channelType): FLOAT 0x80 | SIGNED 0x40.
    for (i, channel) in [0u32, 1, 2, 15].into_iter().enumerate() {
        let word0 = (i as u32 * bits) | ((bits - 1) << 16) | ((channel | 0x80 | 0x40) << 24);
        u32s(&mut d, &[word0, 0, (-1.0f32).to_bits(), 1.0f32.to_bits()]);
    }
    d
}

/// Key/value data: per entry its byte length, key NUL value, padded to 4 bytes (the padding of the
/// last entry included in the total, as the specification asks).
fn key_values(entries: &[(&str, &[u8])]) -> Vec<u8> {
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
mod tests {
    use super::*;

    #[test]
    fn layout_smallest_level_first_and_aligned() {
        let l0 = vec![1.0f32; 6 * 4 * 4 * 4];
        let l1 = vec![2.0f32; 6 * 2 * 2 * 4];
        let l2 = vec![3.0f32; 6 * 4];
        let levels = [
            Level { width: 4, height: 4, rgba: &l0 },
            Level { width: 2, height: 2, rgba: &l1 },
            Level { width: 1, height: 1, rgba: &l2 },
        ];
        for format in [KtxFormat::Rgba16f, KtxFormat::Rgba32f] {
            let b = encode(&levels, 6, format).unwrap();
            assert_eq!(&b[..12], &IDENTIFIER);
            let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
            let offsets: Vec<u64> = (0..3).map(|k| u64_at(80 + 24 * k)).collect();
            assert!(offsets[2] < offsets[1] && offsets[1] < offsets[0]);
            for (k, o) in offsets.iter().enumerate() {
                assert_eq!(o % (4 * format.type_size()) as u64, 0);
                assert_eq!(u64_at(80 + 24 * k + 8), (levels[k].rgba.len() * format.type_size()) as u64);
            }
            assert_eq!(offsets[0] + u64_at(88), b.len() as u64);
        }
    }

    #[test]
    fn refuses_wrong_level_sizes_and_clamps_halves() {
        let l0 = vec![0.0f32; 6 * 4 * 4 * 4];
        let l1 = vec![0.0f32; 6 * 3 * 3 * 4];
        let e = encode(
            &[Level { width: 4, height: 4, rgba: &l0 }, Level { width: 3, height: 3, rgba: &l1 }],
            6,
            KtxFormat::Rgba16f,
        )
        .unwrap_err();
        assert!(e.to_string().contains("level 1 must be 2x2"), "{e}");
        let px = [1.0e5f32, -1.0e5, 0.5, 1.0];
        let b = encode(&[Level { width: 1, height: 1, rgba: &px }], 1, KtxFormat::Rgba16f).unwrap();
        let data = &b[b.len() - 8..];
        let h = |i: usize| f16::from_le_bytes([data[2 * i], data[2 * i + 1]]).to_f32();
        assert_eq!([h(0), h(1), h(2), h(3)], [65504.0, -65504.0, 0.5, 1.0]);
    }
}
