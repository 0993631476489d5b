//! The Data Format Descriptor of a `.ktx2` file: one basic descriptor block (Khronos Data Format
//! Specification 1.3, "Basic descriptor block", version 2), the same, field for field, as Khronos'
//! own generator writes for each Vulkan format (KTX-Software's `dfdutils`, `vk2dfd`), which
//! `ktx validate` compares against; the tests compare ours with the `ktx2` crate's generator.
//!
//! Common to every format: `KHR_DF_MODEL_RGBSDA`, BT.709 primaries, linear transfer, straight
//! alpha, a 1x1x1x1 texel block of `bytesPlane0` bytes. The samples (bit offset, bit length,
//! channel, qualifiers, sampleLower, sampleUpper):
//!
//! - `*_SFLOAT` (RGBA16F, RGBA32F, RG16F): one per channel, R, G, B, A (ids 0, 1, 2, 15), at
//!   consecutive offsets, qualified float and signed, lower -1.0f, upper 1.0f (0xBF800000, 0x3F800000).
//! - `B10G11R11_UFLOAT_PACK32`: R 11 bits at 0, G 11 at 11, B 10 at 22, qualified float
//!   (unsigned), lower 0.0f, upper 1.0f (`createDFDPacked` with `s_UFLOAT`).
//! - `E5B9G9R9_UFLOAT_PACK32`: six samples, each channel's 9-bit mantissa (at 0, 9, 18; no
//!   qualifier, lower 0, upper 8448) followed by the shared 5-bit exponent at 27 under the same
//!   channel id (qualifier exponent, lower 15 = the bias, upper 31), as `createDFDPackedShifted`
//!   writes it and libktx's `texture2.c` compares it byte for byte to recognise the format.

use super::KtxFormat;

/// Sample qualifiers: the top four bits of the channel byte.
const FLOAT: u32 = 0x80;
const SIGNED: u32 = 0x40;
const EXPONENT: u32 = 0x20;

/// Channel ids of the RGBSDA model.
const R: u32 = 0;
const G: u32 = 1;
const B: u32 = 2;
const A: u32 = 15;

/// One sample: bit offset, bit length, channel id with its qualifiers, sampleLower, sampleUpper.
struct Sample(u32, u32, u32, u32, u32);

fn samples(format: KtxFormat) -> Vec<Sample> {
    let (minus_one, one) = ((-1.0f32).to_bits(), 1.0f32.to_bits());
    let sfloat = |bits: u32, channels: &[u32]| {
        channels
            .iter()
            .enumerate()
            .map(|(i, &c)| Sample(i as u32 * bits, bits, c | FLOAT | SIGNED, minus_one, one))
            .collect::<Vec<_>>()
    };
    match format {
        KtxFormat::Rgba16f => sfloat(16, &[R, G, B, A]),
        KtxFormat::Rgba32f => sfloat(32, &[R, G, B, A]),
        KtxFormat::Rg16f => sfloat(16, &[R, G]),
        KtxFormat::Rg11b10f => {
            vec![Sample(0, 11, R | FLOAT, 0, one), Sample(11, 11, G | FLOAT, 0, one), Sample(22, 10, B | FLOAT, 0, one)]
        }
        KtxFormat::Rgb9e5 => [R, G, B]
            .into_iter()
            .enumerate()
            .flat_map(|(i, c)| [Sample(9 * i as u32, 9, c, 0, 8448), Sample(27, 5, c | EXPONENT, 15, 31)])
            .collect(),
    }
}

/// The DFD section: its total size, then the basic descriptor block.
pub fn basic_dfd(format: KtxFormat) -> Vec<u8> {
    let samples = samples(format);
    let block_size = 24 + 16 * samples.len();
    let mut d = Vec::with_capacity(4 + block_size);
    let u32s = |d: &mut Vec<u8>, vs: &[u32]| vs.iter().for_each(|v| d.extend_from_slice(&v.to_le_bytes()));
    u32s(&mut d, &[(4 + block_size) as u32]); // dfdTotalSize
                                              // vendorId 0 (Khronos, 17 bits) | descriptorType 0 (basic, 15 bits); versionNumber 2 | blockSize.
    u32s(&mut d, &[0, 2 | ((block_size as u32) << 16)]);
    // colorModel RGBSDA (1), colorPrimaries BT709 (1), transferFunction linear (1), flags 0 (straight alpha).
    d.extend_from_slice(&[1, 1, 1, 0]);
    d.extend_from_slice(&[0, 0, 0, 0]); // texelBlockDimension 0..3, each stored minus 1: 1x1x1x1
    d.extend_from_slice(&[format.texel_bytes() as u8, 0, 0, 0, 0, 0, 0, 0]); // bytesPlane0..7
    for Sample(offset, bits, channel, lower, upper) in samples {
        // samplePosition0..3 are 0: the one texel of the block.
        u32s(&mut d, &[offset | ((bits - 1) << 16) | (channel << 24), 0, lower, upper]);
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ours against the `ktx2` crate's generator for every format (an independent reading of
    /// the same Khronos tables), parsed back by the crate, and the block sizes by hand.
    #[test]
    fn every_format_matches_the_ktx2_crates_generator() {
        for format in KtxFormat::ALL {
            let vk = ktx2::Format::new(format.vk_format()).expect("a known Vulkan format");
            let (reference, type_size) = ktx2::dfd::Basic::from_format(vk).expect("the crate describes it");
            assert_eq!(type_size as usize, format.type_size(), "{format}: typeSize");
            let ours = basic_dfd(format);
            // After dfdTotalSize and the block header (vendor, type, version, size).
            let basic = ktx2::dfd::Basic::parse(&ours[12..]).expect("a basic DFD block");
            assert_eq!(basic, reference, "{format}");
            let samples = match format {
                KtxFormat::Rgba16f | KtxFormat::Rgba32f => 4,
                KtxFormat::Rg16f => 2,
                KtxFormat::Rg11b10f => 3,
                KtxFormat::Rgb9e5 => 6,
            };
            assert_eq!(ours.len(), 4 + 24 + 16 * samples, "{format}");
            assert_eq!(u32::from_le_bytes(ours[..4].try_into().unwrap()) as usize, ours.len());
        }
    }

    /// The rgb9e5 descriptor word for word, as libktx's comparator holds it.
    #[test]
    fn rgb9e5_descriptor_words() {
        let d = basic_dfd(KtxFormat::Rgb9e5);
        let words: Vec<u32> = d.chunks_exact(4).map(|w| u32::from_le_bytes(w.try_into().unwrap())).collect();
        assert_eq!(&words[..7], &[124, 0, 2 | (120 << 16), 0x0001_0101, 0, 4, 0]);
        for c in 0..3u32 {
            let mantissa = &words[7 + 8 * c as usize..11 + 8 * c as usize];
            let exponent = &words[11 + 8 * c as usize..15 + 8 * c as usize];
            assert_eq!(mantissa, &[(9 * c) | (8 << 16) | (c << 24), 0, 0, 8448]);
            assert_eq!(exponent, &[27 | (4 << 16) | ((c | 0x20) << 24), 0, 15, 31]);
        }
    }
}
