//! The texture formats engines load, written by `Save` from a small image-based-lighting graph
//! (`builtin:sky -> LatLongToCubemap -> PrefilterSpecular`, `ShIrradiance`, `BrdfLut`) and read
//! back by readers that are not hdrflow's:
//!
//! - `.ktx2` in every `ktx_format`, plain and Zstandard-supercompressed (Bevy's samples are
//!   `*_rgb9e5_zstd.ktx2`): the `ktx2` crate parses the file, the `zstd` crate inflates each level,
//!   the texels are decoded here from the Vulkan format's bit layout and compared with the
//!   `Rgba32f` file (the f32 values) within the format's bound;
//! - `.ktx` (KTX 1.1 for Filament): a reader written here from the KTX 1.1 specification that
//!   parses as Filament's `Ktx1Bundle` does (endianness word, key/value entries and their padding,
//!   per level `imageSize` = one face of a non-array cube map, no cube or mip padding), the GL fields
//!   that Filament's `Ktx1Reader` maps, and the `sh` text;
//! - the 16-bit linear PNG of the BRDF LUT, by the `image` crate;
//!
//! and the warnings for clamped texels and dropped channels, and the `sh` input's error.

mod common;

use common::{Output, Sandbox};
use exr::prelude::f16;
use hdrflow::formats::ktx2::KtxFormat;
use hdrflow::formats::packed_float::{decode_b10g11r11, decode_rgb9e5, RGB9E5_MAX, UF10_MAX, UF11_MAX};
use ktx2::{Format, Reader, SupercompressionScheme};

const GRAPH: &str = r#"(
    nodes: {
        "env":  LoadHdr(path: "builtin:sky"),
        "cube": LatLongToCubemap(image: "env", size: 16),
        "spec": PrefilterSpecular(env: "cube", size: 16, levels: 5, samples: 64),
        "sh":   ShIrradiance(env: "env", order: 2),
        "lut":  BrdfLut(size: 16, samples: 64),

        "f32":         Save(input: "spec", path: "spec_Rgba32f.ktx2", ktx_format: Rgba32f),
        "f16":         Save(input: "spec", path: "spec_Rgba16f.ktx2"),
        "rgb9e5":      Save(input: "spec", path: "spec_Rgb9e5.ktx2", ktx_format: Rgb9e5),
        "rg11b10f":    Save(input: "spec", path: "spec_Rg11b10f.ktx2", ktx_format: Rg11b10f),
        "f16_zstd":    Save(input: "spec", path: "spec_Rgba16f_zstd.ktx2", ktx_supercompression: Zstd, zstd_level: 3),
        "rgb9e5_zstd": Save(input: "spec", path: "spec_Rgb9e5_zstd.ktx2", ktx_format: Rgb9e5, ktx_supercompression: Zstd),
        "rg11b10f_zstd": Save(input: "spec", path: "spec_Rg11b10f_zstd.ktx2", ktx_format: Rg11b10f, ktx_supercompression: Zstd),

        "ibl":      Save(input: "spec", path: "spec_ibl.ktx", sh: "sh"),
        "ibl_f16":  Save(input: "spec", path: "spec_ibl_f16.ktx", ktx1_format: Rgba16f),
        "skybox":   Save(input: "cube", path: "skybox.ktx"),
        "cube_f32": Save(input: "cube", path: "cube_Rgba32f.ktx2", ktx_format: Rgba32f),
        "sh_json":  Save(input: "sh", path: "sh.json"),

        "lut_exr":   Save(input: "lut", path: "lut.exr"),
        "lut_rg16f": Save(input: "lut", path: "lut.ktx2", ktx_format: Rg16f),
        "lut_rg16f_zstd": Save(input: "lut", path: "lut_zstd.ktx2", ktx_format: Rg16f, ktx_supercompression: Zstd),
        "lut_png":   Save(input: "lut", path: "lut.png", png_format: Linear16),
    },
)"#;

/// Each level's texels, RGBA (alpha 1 and B 0 where the format has none), from bytes laid out as
/// `format` says (little-endian words).
fn decode(format: KtxFormat, bytes: &[u8]) -> Vec<[f32; 4]> {
    let word = |b: &[u8]| u32::from_le_bytes(b.try_into().unwrap());
    let half = |b: &[u8]| f16::from_le_bytes([b[0], b[1]]).to_f32();
    match format {
        KtxFormat::Rgba32f => bytes
            .chunks_exact(16)
            .map(|t| [0, 4, 8, 12].map(|i| f32::from_le_bytes(t[i..i + 4].try_into().unwrap())))
            .collect(),
        KtxFormat::Rgba16f => bytes.chunks_exact(8).map(|t| [0, 2, 4, 6].map(|i| half(&t[i..]))).collect(),
        KtxFormat::Rg16f => bytes.chunks_exact(4).map(|t| [half(t), half(&t[2..]), 0.0, 1.0]).collect(),
        KtxFormat::Rgb9e5 => bytes
            .chunks_exact(4)
            .map(|t| {
                let [r, g, b] = decode_rgb9e5(word(t));
                [r, g, b, 1.0]
            })
            .collect(),
        KtxFormat::Rg11b10f => bytes
            .chunks_exact(4)
            .map(|t| {
                let [r, g, b] = decode_b10g11r11(word(t));
                [r, g, b, 1.0]
            })
            .collect(),
    }
}

/// Whether `got` is `want` as `format` stores it, within the format's rounding bound (the one
/// its doc comment states); the channels the format lacks are not compared.
fn within_bound(format: KtxFormat, got: [f32; 4], want: [f32; 4]) -> bool {
    let close = |g: f32, w: f32, rel: f64, abs: f64| ((g - w).abs() as f64) <= rel * w.abs() as f64 + abs;
    match format {
        KtxFormat::Rgba32f => got == want,
        KtxFormat::Rgba16f => (0..4).all(|k| close(got[k], want[k], 2f64.powi(-11), 2f64.powi(-25))),
        KtxFormat::Rg16f => (0..2).all(|k| close(got[k], want[k], 2f64.powi(-11), 2f64.powi(-25))),
        KtxFormat::Rgb9e5 => {
            let w = want.map(|v| v.clamp(0.0, RGB9E5_MAX));
            let max_c = w[0].max(w[1]).max(w[2]) as f64;
            (0..3).all(|k| ((got[k] - w[k]).abs() as f64) <= 2f64.powi(-9) * 512.0 / 511.5 * max_c + 2f64.powi(-25))
        }
        KtxFormat::Rg11b10f => {
            let w = [want[0].clamp(0.0, UF11_MAX), want[1].clamp(0.0, UF11_MAX), want[2].clamp(0.0, UF10_MAX)];
            close(got[0], w[0], 2f64.powi(-7), 2f64.powi(-21))
                && close(got[1], w[1], 2f64.powi(-7), 2f64.powi(-21))
                && close(got[2], w[2], 2f64.powi(-6), 2f64.powi(-20))
        }
    }
}

fn vk_format(format: KtxFormat) -> Format {
    match format {
        KtxFormat::Rgba16f => Format::R16G16B16A16_SFLOAT,
        KtxFormat::Rgba32f => Format::R32G32B32A32_SFLOAT,
        KtxFormat::Rgb9e5 => Format::E5B9G9R9_UFLOAT_PACK32,
        KtxFormat::Rg11b10f => Format::B10G11R11_UFLOAT_PACK32,
        KtxFormat::Rg16f => Format::R16G16_SFLOAT,
    }
}

/// Reads a `.ktx2` with the `ktx2` crate: checks the header, the DFD (against the crate's own
/// generator), the level index and layout; returns every level's texels (inflated with `zstd`
/// when supercompressed).
fn read_ktx2(
    bytes: &[u8],
    format: KtxFormat,
    zstd: bool,
    size: (u32, u32),
    faces: u32,
    levels: u32,
) -> Vec<Vec<[f32; 4]>> {
    let r = Reader::new(bytes).expect("the ktx2 crate reads the file");
    let h = r.header();
    assert_eq!(h.format, Some(vk_format(format)));
    assert_eq!(h.format.map(|f| f.value()), Some(format.vk_format()));
    let (reference, type_size) = ktx2::dfd::Basic::from_format(vk_format(format)).expect("a DFD for the format");
    assert_eq!(h.type_size, type_size, "{format}: typeSize");
    assert_eq!((h.pixel_width, h.pixel_height, h.pixel_depth), (size.0, size.1, 0));
    assert_eq!((h.layer_count, h.face_count, h.level_count), (0, faces, levels));
    assert_eq!(h.supercompression_scheme, zstd.then_some(SupercompressionScheme::Zstandard));
    assert_eq!((h.index.sgd_byte_offset, h.index.sgd_byte_length), (0, 0), "Zstandard has no global data");
    assert_eq!(r.dfd_blocks().len(), 1);
    assert_eq!(r.basic_dfd(), Some(&reference), "{format}: the DFD Khronos' generator gives");
    assert_eq!(r.key_value_data().map(|(k, _)| k).collect::<Vec<_>>(), ["KTXorientation", "KTXwriter"]);

    let base = r.data().as_ptr() as usize;
    let kvd_end = (h.index.kvd_byte_offset + h.index.kvd_byte_length) as usize;
    let mut end_of_previous = None;
    let mut out = Vec::new();
    let all: Vec<_> = r.levels().collect();
    for (k, l) in all.iter().enumerate().rev() {
        let texels = faces as usize * (size.0 >> k).max(1) as usize * (size.1 >> k).max(1) as usize;
        let raw_len = texels * format.texel_bytes();
        assert_eq!(l.uncompressed_byte_length, raw_len as u64, "{format} level {k}");
        let offset = l.data.as_ptr() as usize - base;
        // Smallest level first; supercompressed levels follow one another with no padding (the
        // alignment is 1), plain ones are aligned to lcm(texel size, 4).
        let start = end_of_previous.unwrap_or(kvd_end);
        if zstd {
            assert_eq!(offset, start, "{format} level {k} is not right after the previous one");
        } else {
            assert_eq!(offset, start.next_multiple_of(format.texel_bytes()), "{format} level {k}");
            assert_eq!(l.data.len(), raw_len);
        }
        end_of_previous = Some(offset + l.data.len());
        let raw = if zstd { zstd::bulk::decompress(l.data, raw_len).expect("a zstd frame") } else { l.data.to_vec() };
        assert_eq!(raw.len(), raw_len, "{format} level {k}: inflated length");
        out.push(decode(format, &raw));
    }
    assert_eq!(end_of_previous, Some(bytes.len()), "{format}: level 0 ends the file");
    out.reverse();
    out
}

/// A KTX 1.1 file, parsed as Filament's `Ktx1Bundle(bytes, nbytes)` does.
struct Ktx1 {
    fields: [u32; 12],
    key_values: Vec<(String, Vec<u8>)>,
    /// Per level, per face, the bytes.
    faces: Vec<Vec<Vec<u8>>>,
}

fn read_ktx1(bytes: &[u8]) -> Ktx1 {
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
    assert_eq!(&bytes[..12], &[0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31, 0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A], "identifier");
    assert_eq!(u32_at(12), 0x0403_0201, "endianness: a little-endian file");
    // glType, glTypeSize, glFormat, glInternalFormat, glBaseInternalFormat, pixelWidth,
    // pixelHeight, pixelDepth, numberOfArrayElements, numberOfFaces, numberOfMipmapLevels,
    // bytesOfKeyValueData.
    let fields: [u32; 12] = std::array::from_fn(|i| u32_at(16 + 4 * i));
    let (faces, levels, kvd) = (fields[9].max(1) as usize, fields[10].max(1) as usize, fields[11] as usize);
    let mut at = 64;
    let end = at + kvd;
    assert!(end <= bytes.len(), "KTX metadata exceeds buffer");
    let mut key_values = Vec::new();
    while at < end {
        let size = u32_at(at) as usize;
        at += 4;
        assert!(size <= end - at, "KTX metadata entry exceeds metadata block");
        let entry = &bytes[at..at + size];
        let nul = entry.iter().position(|&b| b == 0).expect("KTX metadata key must be null-terminated");
        key_values.push((String::from_utf8(entry[..nul].to_vec()).unwrap(), entry[nul + 1..].to_vec()));
        at += size;
        let padding = 3 - ((size + 3) % 4);
        assert!(bytes[at..at + padding].iter().all(|&b| b == 0), "valuePadding is zero");
        at += padding;
    }
    assert_eq!(at, end, "the key/value data add up to bytesOfKeyValueData");
    let non_array_cube = faces == 6 && fields[8] == 0;
    let mut data = Vec::new();
    for _ in 0..levels {
        let image_size = u32_at(at) as usize;
        at += 4;
        let face_size = if non_array_cube { image_size } else { image_size / faces };
        let level = (0..faces).map(|f| bytes[at + f * face_size..at + (f + 1) * face_size].to_vec()).collect();
        // cubePadding and mipPadding: none, as every face is a multiple of 4 bytes.
        assert_eq!(face_size % 4, 0);
        at += face_size * faces;
        data.push(level);
    }
    assert_eq!(at, bytes.len(), "nothing after the last level");
    Ktx1 { fields, key_values, faces: data }
}

#[test]
fn every_engine_format_reads_back_within_its_bound() {
    let sb = Sandbox::new();
    let graph = sb.write("graph.ron", GRAPH);
    let (out, _) = sb.run_ok(&graph, &[]);
    let file = |name: &str| common::read_file(&sb.out().join(name));

    // The f32 chain is the reference: exact, so the chain's own values.
    let reference = read_ktx2(&file("spec_Rgba32f.ktx2"), KtxFormat::Rgba32f, false, (16, 16), 6, 5);
    let mut compared = 0;
    for (name, format, zstd) in [
        ("spec_Rgba16f.ktx2", KtxFormat::Rgba16f, false),
        ("spec_Rgb9e5.ktx2", KtxFormat::Rgb9e5, false),
        ("spec_Rg11b10f.ktx2", KtxFormat::Rg11b10f, false),
        ("spec_Rgba16f_zstd.ktx2", KtxFormat::Rgba16f, true),
        ("spec_Rgb9e5_zstd.ktx2", KtxFormat::Rgb9e5, true),
        ("spec_Rg11b10f_zstd.ktx2", KtxFormat::Rg11b10f, true),
    ] {
        let levels = read_ktx2(&file(name), format, zstd, (16, 16), 6, 5);
        for (k, (got, want)) in levels.iter().zip(&reference).enumerate() {
            assert_eq!(got.len(), want.len());
            for (i, (g, w)) in got.iter().zip(want).enumerate() {
                assert!(within_bound(format, *g, *w), "{name} level {k} texel {i}: read {g:?}, wrote {w:?}");
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 6 * 6 * (256 + 64 + 16 + 4 + 1));
    // A zstd file is smaller than the plain one of the same format.
    assert!(file("spec_Rgb9e5_zstd.ktx2").len() < file("spec_Rgb9e5.ktx2").len());

    // The BRDF LUT: R16G16_SFLOAT, plain and zstd, and the 16-bit PNG, against the EXR's f32.
    let lut = hdrflow::formats::exr::decode(&file("lut.exr")).expect("the LUT as EXR");
    let want: Vec<[f32; 4]> = (0..16 * 16)
        .map(|i| {
            let [r, g, _] = lut.rgb(i % 16, i / 16);
            [r, g, 0.0, 1.0]
        })
        .collect();
    for (name, zstd) in [("lut.ktx2", false), ("lut_zstd.ktx2", true)] {
        let got = read_ktx2(&file(name), KtxFormat::Rg16f, zstd, (16, 16), 1, 1);
        for (i, (g, w)) in got[0].iter().zip(&want).enumerate() {
            assert!(within_bound(KtxFormat::Rg16f, *g, *w), "{name} texel {i}: read {g:?}, wrote {w:?}");
        }
    }
    let png = image::load_from_memory(&file("lut.png")).expect("the PNG decodes");
    assert_eq!(png.color(), image::ColorType::Rgb16, "16 bits, RGB");
    let png = png.to_rgb16();
    for (i, w) in want.iter().enumerate() {
        let p = png.get_pixel((i % 16) as u32, (i / 16) as u32).0;
        for k in 0..2 {
            let code = (w[k].clamp(0.0, 1.0) * 65535.0).round() as u16;
            assert_eq!(p[k], code, "lut.png texel {i} channel {k}: {p:?} for {w:?}");
        }
        assert_eq!(p[2], 0, "B = 0");
    }

    // KTX 1.1 for Filament: the fields its reader maps, the sh text, and the texels.
    let sh: serde_json::Value = serde_json::from_slice(&file("sh.json")).unwrap();
    let coefficients: Vec<[f64; 3]> =
        sh["coefficients"].as_array().unwrap().iter().map(|c| [0, 1, 2].map(|k| c[k].as_f64().unwrap())).collect();
    let cube_ref = read_ktx2(&file("cube_Rgba32f.ktx2"), KtxFormat::Rgba32f, false, (16, 16), 6, 1);
    for (name, format, levels, want) in [
        ("spec_ibl.ktx", KtxFormat::Rg11b10f, 5, &reference),
        ("spec_ibl_f16.ktx", KtxFormat::Rgba16f, 5, &reference),
        ("skybox.ktx", KtxFormat::Rg11b10f, 1, &cube_ref),
    ] {
        let k1 = read_ktx1(&file(name));
        let gl = match format {
            // Filament's Ktx1Reader: glType 0x8C3A -> UINT_10F_11F_11F_REV, glFormat RGB,
            // glInternalFormat R11F_G11F_B10F; HALF_FLOAT, RGBA, RGBA16F.
            KtxFormat::Rg11b10f => [0x8C3A, 4, 0x1907, 0x8C3A, 0x1907],
            _ => [0x140B, 2, 0x1908, 0x881A, 0x1908],
        };
        assert_eq!(k1.fields, [gl[0], gl[1], gl[2], gl[3], gl[4], 16, 16, 0, 0, 6, levels, k1.fields[11]], "{name}");
        if name == "spec_ibl.ktx" {
            assert_eq!(k1.key_values.len(), 1);
            let (key, value) = &k1.key_values[0];
            assert_eq!(key, "sh");
            let text = std::str::from_utf8(value).expect("text");
            assert_eq!(text, hdrflow::formats::ktx1::sh_text(&coefficients).unwrap(), "cmgen's text of sh.json");
            // What Ktx1Bundle::getSphericalHarmonics reads: 27 floats, each within float printing.
            let floats: Vec<f32> = text.split_whitespace().map(|t| t.parse().unwrap()).collect();
            assert_eq!(floats.len(), 27);
            for (f, c) in floats.iter().zip(coefficients.iter().flatten()) {
                assert!((*f as f64 - c).abs() <= 1e-5 * c.abs().max(1e-3), "{f} for {c}");
            }
        } else {
            assert!(k1.key_values.is_empty(), "{name}: {:?}", k1.key_values);
        }
        for (k, faces) in k1.faces.iter().enumerate() {
            let face_texels = ((16 >> k) as usize).pow(2);
            for (f, bytes) in faces.iter().enumerate() {
                let got = decode(format, bytes);
                assert_eq!(got.len(), face_texels);
                let want = &want[k][f * face_texels..(f + 1) * face_texels];
                for (i, (g, w)) in got.iter().zip(want).enumerate() {
                    assert!(within_bound(format, *g, *w), "{name} level {k} face {f} texel {i}: {g:?} for {w:?}");
                }
            }
        }
    }
    assert!(!out.stderr.contains("warning"), "no texel is out of range here:\n{}", out.describe());
}

/// The warning lines of node `node` on a run's stderr.
fn warnings_of<'a>(out: &'a Output, node: &str) -> Vec<&'a str> {
    out.stderr.lines().filter(|l| l.starts_with(&format!("warning: node \"{node}\""))).collect()
}

#[test]
fn out_of_range_texels_are_clamped_with_one_warning_naming_their_count() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "graph.ron",
        r#"(
    nodes: {
        "hot":  Constant(width: 8, height: 4, color: 100000),
        "cold": Constant(width: 8, height: 4, color: -1),
        "cube": LatLongToCubemap(image: "hot", size: 2),
        "a": Save(input: "hot", path: "hot.ktx2", ktx_format: Rgb9e5),
        "b": Save(input: "cold", path: "cold.ktx2", ktx_format: Rg11b10f, ktx_supercompression: Zstd),
        "c": Save(input: "cube", path: "cube.ktx"),
        "d": Save(input: "cube", path: "cube_rg.ktx2", ktx_format: Rg16f),
        "e": Save(input: "hot", path: "hot_rgba.ktx2", ktx_format: Rgba32f),
    },
)"#,
    );
    let (out, _) = sb.run_ok(&graph, &[]);
    let lines = |node: &str| warnings_of(&out, node);
    assert_eq!(
        lines("a"),
        ["warning: node \"a\": hot.ktx2: 32 texels have values that ktx_format Rgb9e5 cannot hold: values outside [0, 65408] are clamped to it (NaN to 0)"],
        "{}",
        out.describe()
    );
    assert_eq!(
        lines("b"),
        ["warning: node \"b\": cold.ktx2: 32 texels have values that ktx_format Rg11b10f cannot hold: values outside [0, 65024] ([0, 64512] for B) are clamped to it (NaN to 0)"]
    );
    assert_eq!(
        lines("c"),
        ["warning: node \"c\": cube.ktx: 24 texels have values that ktx1_format Rg11b10f cannot hold: values outside [0, 65024] ([0, 64512] for B) are clamped to it (NaN to 0)"]
    );
    let d = lines("d");
    assert_eq!(d.len(), 2, "{d:?}");
    assert!(
        d.iter()
            .any(|l| l
                .ends_with("cube_rg.ktx2: .ktx2 holds RG with ktx_format Rg16f: channel B of the cube map is dropped")),
        "{d:?}"
    );
    assert!(
        d.iter().any(|l| l.contains("24 texels have values that ktx_format Rg16f cannot hold: values beyond +-65504")),
        "{d:?}"
    );
    assert!(lines("e").is_empty(), "{}", out.describe());
    // Clamped to the largest value, not infinite; the negatives to 0.
    let hot = read_ktx2(&common::read_file(&sb.out().join("hot.ktx2")), KtxFormat::Rgb9e5, false, (8, 4), 1, 1);
    assert!(hot[0].iter().all(|t| t[..3] == [RGB9E5_MAX; 3]), "{:?}", &hot[0][..2]);
    let cold = Reader::new(common::read_file(&sb.out().join("cold.ktx2"))).unwrap().levels().next().map(|l| {
        decode(KtxFormat::Rg11b10f, &zstd::bulk::decompress(l.data, l.uncompressed_byte_length as usize).unwrap())
    });
    assert!(cold.unwrap().iter().all(|t| t[..3] == [0.0; 3]));
}

#[test]
fn sh_with_other_than_three_bands_is_an_error_naming_the_count() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "graph.ron",
        r#"(
    nodes: {
        "env":  LoadHdr(path: "builtin:sky"),
        "cube": LatLongToCubemap(image: "env", size: 4),
        "sh":   ShIrradiance(env: "env", order: 1),
        "ibl":  Save(input: "cube", path: "ibl.ktx", sh: "sh"),
    },
)"#,
    );
    let (out, _) = sb.run(&graph, &[]);
    assert_ne!(out.code, Some(0), "{}", out.describe());
    out.assert_stderr_contains(
        "encoding ibl.ktx: the sh input: Filament reads 3 bands (9 RGB coefficients) from the KTX key sh, but 4 were given",
    );
}

#[test]
fn hdrflow_ops_save_documents_the_choices() {
    let o = common::run_hdrflow(["ops", "Save"]);
    o.assert_success();
    for word in [
        "ktx_format",
        "Rgb9e5",
        "Rg11b10f",
        "Rg16f",
        "ktx_supercompression",
        "Zstd",
        "zstd_level",
        "ktx1_format",
        "png_format",
        "Linear16",
        "\"sh\"",
    ] {
        o.assert_stdout_contains(word);
    }
}

/// An RGBP `.png` (PlayCanvas) clamps values beyond 64 with one warning counting them, for a cube
/// map (written as its strip) as for an image.
#[test]
fn rgbp_pngs_of_images_and_cube_maps_count_their_clamped_texels() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "graph.ron",
        r#"(
    nodes: {
        "hot":  Constant(width: 8, height: 4, color: 100),
        "cube": LatLongToCubemap(image: "hot", size: 2),
        "a": Save(input: "hot", path: "hot.png", png_format: Rgbp),
        "b": Save(input: "cube", path: "cube.png", png_format: Rgbp),
    },
)"#,
    );
    let (out, _) = sb.run_ok(&graph, &[]);
    let lines = |node: &str| warnings_of(&out, node);
    assert_eq!(
        lines("a"),
        ["warning: node \"a\": hot.png: 32 texels are beyond RGBP's range (64) clamped to it (colour kept)"],
        "{}",
        out.describe()
    );
    assert_eq!(
        lines("b"),
        ["warning: node \"b\": cube.png: 24 texels are beyond RGBP's range (64) clamped to it (colour kept)"],
        "{}",
        out.describe()
    );
}
