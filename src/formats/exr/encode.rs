//! Writing: one layer, one EXR channel per image channel, the chosen compression, f32 or half.

use std::io::Cursor;

use ::exr::prelude::traits::*;
use ::exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, LayerAttributes, SmallVec};

use super::{caught, PARALLEL_MIN_PIXELS};
use crate::formats::FormatError;
use crate::values::Image;

crate::choice! {
    /// The compression of a written EXR file (what the `exr` crate writes).
    pub enum ExrCompression {
        /// deflate, 16-line blocks (OpenEXR's ZIP_COMPRESSION), lossless
        Zip,
        /// run-length encoding, one line a block, lossless (OpenEXR's RLE_COMPRESSION): fast, and small
        /// for images with large flat areas (a render's transparent background)
        Rle,
        /// wavelet + Huffman, 32-line blocks, lossless
        Piz,
        /// DWAA (DCT, 32-line blocks, default level 45): lossy (about 2e-3 at values near 0.5, f32 or half)
        Dwaa,
        /// uncompressed
        None,
    }
}

/// How [`encode_with`] writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncodeOptions {
    pub compression: ExrCompression,
    /// Half floats instead of f32 (values beyond 65504 become infinite, as OpenEXR's conversion).
    pub half: bool,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions { compression: ExrCompression::Zip, half: false }
    }
}

/// Encodes `image` as a ZIP-compressed float32 OpenEXR file, one EXR channel per image channel
/// under the image's channel names (`R G B`, `R G B A`, `Y`, `Z`, ...).
pub fn encode(image: &Image) -> Result<Vec<u8>, FormatError> {
    encode_with(image, &EncodeOptions::default())
}

/// Encodes `image` as an OpenEXR file with the given compression and sample type, one EXR
/// channel per image channel under the image's channel names (alpha `A` kept).
pub fn encode_with(image: &Image, options: &EncodeOptions) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    if w == 0 || h == 0 {
        return Err(FormatError::Invalid(format!("cannot write an empty {w}x{h} image as EXR")));
    }
    if c == 0 || image.names.len() != c {
        return Err(FormatError::Invalid(format!(
            "cannot write an image with {c} channels and {} names as EXR",
            image.names.len()
        )));
    }
    let mut sorted = image.names.clone();
    sorted.sort();
    sorted.dedup();
    if sorted.len() != c || sorted.iter().any(|n| n.is_empty()) {
        return Err(FormatError::Invalid(format!("EXR channel names must be unique and non-empty: {:?}", image.names)));
    }
    let pixels = w * h;
    if image.data.len() != pixels * c {
        return Err(FormatError::Invalid(format!(
            "image buffer has {} samples, expected {w}x{h}x{c}",
            image.data.len()
        )));
    }
    caught(|| encode_inner(image, options), FormatError::EncoderPanicked)
}

pub(super) fn encode_inner(image: &Image, options: &EncodeOptions) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    let samples = |v: Vec<f32>| -> FlatSamples {
        if options.half {
            FlatSamples::F16(v.into_iter().map(::exr::prelude::f16::from_f32).collect())
        } else {
            FlatSamples::F32(v)
        }
    };
    let list: Vec<AnyChannel<FlatSamples>> = if c == 1 {
        vec![AnyChannel::new(image.names[0].as_str(), samples(image.data.clone()))]
    } else {
        let plane = |k: usize| -> Vec<f32> { image.data.chunks_exact(c).map(|p| p[k]).collect() };
        (0..c).map(|k| AnyChannel::new(image.names[k].as_str(), samples(plane(k)))).collect()
    };
    let channels = AnyChannels::sort(SmallVec::from_vec(list));
    // Scanline blocks, increasing Y.
    let compression = match options.compression {
        ExrCompression::Zip => ::exr::prelude::Compression::ZIP16,
        ExrCompression::Rle => ::exr::prelude::Compression::RLE,
        ExrCompression::Piz => ::exr::prelude::Compression::PIZ,
        ExrCompression::Dwaa => ::exr::prelude::Compression::DWAA(None),
        ExrCompression::None => ::exr::prelude::Compression::Uncompressed,
    };
    let encoding = Encoding { compression, ..Encoding::SMALL_LOSSLESS };
    let layer = ::exr::prelude::Layer::new((w, h), LayerAttributes::default(), encoding, channels);
    let exr_image = ::exr::prelude::Image::from_layer(layer);
    let mut out: Vec<u8> = Vec::new();
    let writer = exr_image.write();
    let writer = if w * h < PARALLEL_MIN_PIXELS { writer.non_parallel() } else { writer };
    writer.to_buffered(Cursor::new(&mut out)).map_err(|e| FormatError::Invalid(format!("EXR encoding failed: {e}")))?;
    Ok(out)
}
