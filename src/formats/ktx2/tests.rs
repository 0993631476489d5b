//! Tests of the KTX2 writer: headers, levels, each texel format and its clamping, supercompression.

use super::*;

/// A cube map written from its RGB levels is the file written from their RGBA copies, byte
/// for byte, in every format and both supercompressions (levels larger than one encoding
/// block included).
#[test]
fn rgb_levels_write_the_same_file_as_rgba_ones() {
    let rgb: Vec<Vec<f32>> = [300usize, 150, 75]
        .iter()
        .map(|&s| (0..6 * s * s * 3).map(|i| ((i * 7919) % 1000) as f32 * 0.37 - 20.0).collect())
        .collect();
    let rgba: Vec<Vec<f32>> = rgb.iter().map(|l| rgb_to_rgba(l)).collect();
    let sizes = [300usize, 150, 75];
    let as_rgb: Vec<RgbLevel> =
        sizes.iter().zip(&rgb).map(|(&s, l)| RgbLevel { width: s, height: s, rgb: l }).collect();
    let as_rgba: Vec<Level> = sizes.iter().zip(&rgba).map(|(&s, l)| Level { width: s, height: s, rgba: l }).collect();
    for format in [KtxFormat::Rgba16f, KtxFormat::Rgba32f, KtxFormat::Rgb9e5, KtxFormat::Rg11b10f] {
        for scheme in [KtxSupercompression::None, KtxSupercompression::Zstd] {
            let c = Compression { scheme, ..Compression::default() };
            let a = encode_rgb_with(&as_rgb, 6, format, c).unwrap();
            let b = encode_with(&as_rgba, 6, format, c).unwrap();
            assert!(a == b, "{format:?} {scheme:?}: the files differ");
        }
    }
    // The RGB path checks its value count per three.
    let short = [RgbLevel { width: 2, height: 2, rgb: &[0.0; 12] }];
    assert!(encode_rgb_with(&short, 6, KtxFormat::Rgba16f, Compression::default()).is_err());
}

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

/// The 4-byte formats: aligned to 4, the level lengths of 4 bytes per texel, the texels the
/// packed encoders' words.
#[test]
fn packed_formats_lay_out_four_byte_texels() {
    let l0 = [0.5f32, 0.25, 2.0, 1.0].repeat(6 * 4);
    let l1 = [1.0f32, 3.0, 0.125, 1.0].repeat(6);
    let levels = [Level { width: 2, height: 2, rgba: &l0 }, Level { width: 1, height: 1, rgba: &l1 }];
    for format in [KtxFormat::Rgb9e5, KtxFormat::Rg11b10f, KtxFormat::Rg16f] {
        let b = encode(&levels, 6, format).unwrap();
        let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
        let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
        assert_eq!((u32_at(12), u32_at(16)), (format.vk_format(), format.type_size() as u32));
        for (k, level) in levels.iter().enumerate() {
            let (offset, length) = (u64_at(80 + 24 * k), u64_at(88 + 24 * k));
            assert_eq!(offset % 4, 0);
            assert_eq!(length, (level.rgba.len() / 4 * 4) as u64);
            assert_eq!(u64_at(96 + 24 * k), length);
        }
        let last = u32::from_le_bytes(b[b.len() - 4..].try_into().unwrap());
        match format {
            KtxFormat::Rgb9e5 => assert_eq!(packed_float::decode_rgb9e5(last), [0.5, 0.25, 2.0]),
            KtxFormat::Rg11b10f => assert_eq!(packed_float::decode_b10g11r11(last), [0.5, 0.25, 2.0]),
            _ => assert_eq!([last as u16, (last >> 16) as u16].map(|h| f16::from_bits(h).to_f32()), [0.5, 0.25]),
        }
    }
}

#[test]
fn zstd_levels_are_packed_without_padding_and_decompress_to_the_texels() {
    let l0: Vec<f32> = (0..6 * 16 * 16 * 4).map(|i| (i % 37) as f32 * 0.25).collect();
    let l1: Vec<f32> = (0..6 * 8 * 8 * 4).map(|i| (i % 11) as f32).collect();
    let levels = [Level { width: 16, height: 16, rgba: &l0 }, Level { width: 8, height: 8, rgba: &l1 }];
    for format in KtxFormat::ALL {
        let zstd = Compression { scheme: KtxSupercompression::Zstd, zstd_level: 3 };
        let b = encode_with(&levels, 6, format, zstd).unwrap();
        let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
        let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
        assert_eq!(u32_at(44), 2, "supercompressionScheme");
        assert_eq!((u64_at(64), u64_at(72)), (0, 0), "no supercompression global data");
        let kvd_end = (u32_at(56) + u32_at(60)) as u64;
        let (o1, n1, o0, n0) = (u64_at(104), u64_at(112), u64_at(80), u64_at(88));
        assert_eq!((o1, o1 + n1, o0 + n0), (kvd_end, o0, b.len() as u64), "{format}: levels one after the other");
        for (k, (offset, length)) in [(o0, n0), (o1, n1)].into_iter().enumerate() {
            let raw = format.encode_texels(levels[k].rgba);
            let unpacked = zstd::bulk::decompress(&b[offset as usize..(offset + length) as usize], raw.len()).unwrap();
            assert_eq!(unpacked, raw, "{format} level {k}");
            assert_eq!(u64_at(96 + 24 * k), raw.len() as u64, "uncompressedByteLength");
            assert!(length < raw.len() as u64, "{format} level {k} did not shrink");
        }
    }
    let e =
        encode_with(&levels, 6, KtxFormat::Rgba16f, Compression { scheme: KtxSupercompression::Zstd, zstd_level: 23 });
    assert_eq!(e.unwrap_err().to_string(), "zstd level 23 is out of range (1 to 22)");
}

#[test]
fn clamps_names_exactly_the_texels_the_encoder_changes() {
    let cases: [([f32; 4], [bool; 5]); 7] = [
        // Rgba16f, Rgba32f, Rgb9e5, Rg11b10f, Rg16f
        ([1.0, 2.0, 3.0, 1.0], [false; 5]),
        ([7e4, 0.0, 0.0, 1.0], [true, false, true, true, true]),
        ([0.0, 0.0, 65300.0, 1.0], [false, false, false, true, false]),
        ([-1.0, 0.0, 0.0, 1.0], [false, false, true, true, false]),
        ([0.0, f32::NAN, 0.0, 1.0], [false, false, true, true, true]),
        ([0.0, 0.0, f32::NAN, 1.0], [false, false, true, true, false]),
        ([0.0, 0.0, 0.0, 1e6], [true, false, false, false, false]),
    ];
    for (rgba, want) in cases {
        for (format, want) in KtxFormat::ALL.into_iter().zip(want) {
            assert_eq!(format.clamps(rgba), want, "{format} {rgba:?}");
        }
    }
}
