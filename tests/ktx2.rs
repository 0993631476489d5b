//! `.ktx2` files written by `Save`, read back by an independent reader (the `ktx2` crate): header
//! fields, level index and layout, the Data Format Descriptor (compared with the `ktx2` crate's
//! own DFD generator for the format), key/value data, and the texel values, for an image, a cube
//! map and a mip chain, in RGBA16F and RGBA32F; and `graphs/ibl.ron` end to end.

mod common;

use exr::prelude::f16;
use hdrflow::engine::save::SaveOptions;
use hdrflow::formats::ktx2::KtxFormat;
use hdrflow::values::{Cubemap, Image, MipChain};
use hdrflow::Value;
use ktx2::{dfd, ColorModel, Format, Reader, TransferFunction};

fn save(value: Value, format: KtxFormat) -> Result<Vec<u8>, String> {
    let options = SaveOptions::new("ktx2").with(format);
    (hdrflow::builtin_registry().saver(value.value_type()).unwrap().save)(&value, &options)
}

/// A deterministic spread of values: signed, tiny and large.
fn values(n: usize, seed: u32) -> Vec<f32> {
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(12345);
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let u = s as f32 / u32::MAX as f32;
            (u - 0.2) * 10f32.powf(4.0 * u - 2.0)
        })
        .collect()
}

/// The texels of every level, decoded to f32 from the reader's level slices.
fn decode_levels(r: &Reader<&[u8]>, format: KtxFormat) -> Vec<Vec<f32>> {
    r.levels()
        .map(|l| match format {
            KtxFormat::Rgba16f => l.data.chunks_exact(2).map(|b| f16::from_le_bytes([b[0], b[1]]).to_f32()).collect(),
            KtxFormat::Rgba32f => l.data.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect(),
            other => panic!("{other} is read back by tests/ktx_formats.rs"),
        })
        .collect()
}

/// Within f16 rounding (relative 2^-11, absolute for subnormals), or exact for f32.
fn assert_close(got: &[f32], want: &[f32], format: KtxFormat, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let ok = match format {
            KtxFormat::Rgba32f => g.to_bits() == w.to_bits(),
            KtxFormat::Rgba16f => (g - w).abs() <= w.abs() * 2f32.powi(-11) + 2f32.powi(-25),
            other => panic!("{other} is read back by tests/ktx_formats.rs"),
        };
        assert!(ok, "{what}: value {i}: read {g}, wrote {w}");
    }
}

/// Checks everything but the texels; returns the reader.
fn check_file(bytes: &[u8], format: KtxFormat, size: (u32, u32), faces: u32, levels: u32) -> Reader<&[u8]> {
    let r = Reader::new(bytes).expect("the ktx2 crate reads the file");
    let h = r.header();
    let (vk, ts) = match format {
        KtxFormat::Rgba16f => (Format::R16G16B16A16_SFLOAT, 2),
        KtxFormat::Rgba32f => (Format::R32G32B32A32_SFLOAT, 4),
        other => panic!("{other} is read back by tests/ktx_formats.rs"),
    };
    assert_eq!(h.format, Some(vk));
    assert_eq!(vk.value(), if ts == 2 { 97 } else { 109 });
    assert_eq!(h.type_size, ts);
    assert_eq!((h.pixel_width, h.pixel_height, h.pixel_depth), (size.0, size.1, 0));
    assert_eq!((h.layer_count, h.face_count, h.level_count), (0, faces, levels));
    assert_eq!(h.supercompression_scheme, None);
    assert_eq!(h.index.sgd_byte_length, 0);

    // The DFD: one basic block, the same as Khronos' generator gives for the format.
    assert_eq!(r.dfd_blocks().len(), 1);
    let basic = r.basic_dfd().expect("a basic DFD block");
    assert_eq!(basic.color_model, Some(ColorModel::RGBSDA));
    assert_eq!(basic.transfer_function, Some(TransferFunction::Linear));
    assert_eq!(basic.sample_information.len(), 4);
    let bits = 8 * ts;
    for (i, s) in basic.sample_information.iter().enumerate() {
        assert_eq!(s.bit_length.get() as u32, bits);
        assert_eq!(s.bit_offset as u32, i as u32 * bits);
        assert_eq!(s.channel_type, [0, 1, 2, 15][i]);
        assert!(s
            .channel_type_qualifiers
            .contains(dfd::ChannelTypeQualifiers::FLOAT | dfd::ChannelTypeQualifiers::SIGNED));
        assert_eq!(s.upper, 1.0f32.to_bits());
    }
    let (reference, ref_type_size) = dfd::Basic::from_format(vk).unwrap();
    assert_eq!(basic, &reference);
    assert_eq!(ref_type_size, ts);

    // Key/value data.
    assert_eq!(r.writer(), Some(format!("hdrflow {}\0", env!("CARGO_PKG_VERSION")).as_str()));
    let kv: Vec<(&str, &[u8])> = r.key_value_data().collect();
    assert_eq!(kv.iter().map(|(k, _)| *k).collect::<Vec<_>>(), ["KTXorientation", "KTXwriter"]);
    assert_eq!(kv[0].1, b"rd\0");

    // Levels: sizes, alignment, and the data laid out from the smallest level to the largest.
    let base = r.data().as_ptr() as usize;
    let mut previous_offset = usize::MAX;
    for (k, l) in r.levels().enumerate() {
        let (w, hgt) = ((size.0 >> k).max(1) as usize, (size.1 >> k).max(1) as usize);
        assert_eq!(l.data.len(), faces as usize * w * hgt * 4 * ts as usize, "level {k}");
        assert_eq!(l.uncompressed_byte_length, l.data.len() as u64);
        let offset = l.data.as_ptr() as usize - base;
        assert_eq!(offset % (4 * ts as usize), 0, "level {k} offset {offset}");
        assert!(offset < previous_offset, "level {k} is not stored before level {}", k.saturating_sub(1));
        previous_offset = offset;
    }
    assert_eq!(r.levels().next().map(|l| l.data.as_ptr() as usize - base + l.data.len()), Some(bytes.len()));
    r
}

const FORMATS: [KtxFormat; 2] = [KtxFormat::Rgba16f, KtxFormat::Rgba32f];

fn rgba(rgb: &[f32]) -> Vec<f32> {
    rgb.chunks(3).flat_map(|c| [c[0], c[1], c[2], 1.0]).collect()
}

#[test]
fn image_rgb_grey_and_rgba() {
    let (w, h) = (7, 3);
    let rgb = Image::from_vec(w, h, 3, values(w * h * 3, 1));
    let grey = Image::from_vec(w, h, 1, values(w * h, 2));
    let with_alpha = Image::with_names(w, h, ["R", "G", "B", "A"].map(String::from).to_vec(), values(w * h * 4, 3));
    for format in FORMATS {
        let bytes = save(Value::new(rgb.clone()), format).unwrap();
        let r = check_file(&bytes, format, (w as u32, h as u32), 1, 1);
        assert_close(&decode_levels(&r, format)[0], &rgba(&rgb.data), format, "rgb");

        let bytes = save(Value::new(grey.clone()), format).unwrap();
        let r = check_file(&bytes, format, (w as u32, h as u32), 1, 1);
        let want: Vec<f32> = grey.data.iter().flat_map(|&v| [v, v, v, 1.0]).collect();
        assert_close(&decode_levels(&r, format)[0], &want, format, "grey");

        let bytes = save(Value::new(with_alpha.clone()), format).unwrap();
        let r = check_file(&bytes, format, (w as u32, h as u32), 1, 1);
        assert_close(&decode_levels(&r, format)[0], &with_alpha.data, format, "rgba");
    }
}

#[test]
fn cube_map_and_chain_in_one_file() {
    let cube = |size: usize, seed: u32| Cubemap { size, data: values(18 * size * size, seed) };
    let c = cube(8, 4);
    let chain =
        MipChain { levels: vec![c.clone(), cube(4, 5), cube(2, 6), cube(1, 7)], roughness: vec![0.0, 0.33, 0.67, 1.0] };
    for format in FORMATS {
        let bytes = save(Value::new(c.clone()), format).unwrap();
        let r = check_file(&bytes, format, (8, 8), 6, 1);
        assert_close(&decode_levels(&r, format)[0], &rgba(&c.data), format, "cube");

        let bytes = save(Value::new(chain.clone()), format).unwrap();
        let r = check_file(&bytes, format, (8, 8), 6, 4);
        for (k, (got, level)) in decode_levels(&r, format).iter().zip(&chain.levels).enumerate() {
            assert_close(got, &rgba(&level.data), format, &format!("chain level {k}"));
        }
    }
}

#[test]
fn half_clamps_the_sun_and_bad_chains_are_refused() {
    let c = Cubemap { size: 1, data: [69120.0f32, -1e6, 0.25].repeat(6) };
    let bytes = save(Value::new(c.clone()), KtxFormat::Rgba16f).unwrap();
    let r = check_file(&bytes, KtxFormat::Rgba16f, (1, 1), 6, 1);
    assert_eq!(&decode_levels(&r, KtxFormat::Rgba16f)[0][..4], &[65504.0, -65504.0, 0.25, 1.0]);
    let bytes = save(Value::new(c), KtxFormat::Rgba32f).unwrap();
    let r = check_file(&bytes, KtxFormat::Rgba32f, (1, 1), 6, 1);
    assert_eq!(&decode_levels(&r, KtxFormat::Rgba32f)[0][..4], &[69120.0, -1e6, 0.25, 1.0]);

    let bad = MipChain { levels: vec![Cubemap::new(8), Cubemap::new(3)], roughness: vec![0.0, 1.0] };
    let e = save(Value::new(bad), KtxFormat::Rgba16f).unwrap_err();
    assert!(e.contains("level 1 must be 4x4"), "{e}");
}

#[test]
fn ibl_graph_writes_the_chain_and_the_cube_as_ktx2() {
    let sb = common::Sandbox::new();
    let graph = std::path::Path::new(common::MANIFEST_DIR).join("graphs/ibl.ron");
    let (out, _) = sb.run_ok(&graph, &[]);
    let exr = |name: &str| -> Cubemap {
        let bytes = common::read_file(&sb.out().join(name));
        let strip =
            hdrflow::formats::exr::decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e:?}\n{}", out.describe()));
        Cubemap::from_strip(&strip).unwrap()
    };
    let format = KtxFormat::Rgba16f;
    let bytes = common::read_file(&sb.out().join("cube.ktx2"));
    let r = check_file(&bytes, format, (64, 64), 6, 1);
    assert_close(&decode_levels(&r, format)[0], &rgba(&exr("cubemap.exr").data), format, "cube.ktx2");

    let bytes = common::read_file(&sb.out().join("spec.ktx2"));
    let r = check_file(&bytes, format, (64, 64), 6, 5);
    for (k, got) in decode_levels(&r, format).iter().enumerate() {
        assert_close(got, &rgba(&exr(&format!("spec_{k}.exr")).data), format, &format!("spec.ktx2 level {k}"));
    }
}
