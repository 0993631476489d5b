//! The deliberate mistakes that `hdrflow bake --set` cannot make, made on the cube maps a correct
//! bake wrote (Bevy's `{name}_{specular,diffuse}_rgb9e5_zstd.ktx2`, the Khronos preset's
//! `ggx/specular.ktx2` and `lambertian/diffuse.ktx2`): two faces swapped, the irradiance not
//! divided by pi. (The map not mirrored in z and another roughness map are bakes with `--set`:
//! `bevy_render.rs`, `khronos_render.rs`.)
//!
//! The files are read as the bake writes them (KTX 2.0 specification, sections 3.1-3.9: the
//! header, the level index; `E5B9G9R9_UFLOAT_PACK32` words with `supercompressionScheme` 2, each
//! level one Zstandard frame, or `R16G16B16A16_SFLOAT` texels uncompressed; face by face), edited,
//! and written again with hdrflow's own encoder in the same format. Decoding an rgb9e5 word or a
//! half float and encoding the value again gives the same bits, so an edit changes only what it
//! means to.

use hdrflow::formats::ktx2::{encode_with, Compression, KtxFormat, KtxSupercompression, Level, IDENTIFIER};
use hdrflow::formats::packed_float::decode_rgb9e5;

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn u64_at(b: &[u8], at: usize) -> usize {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes")) as usize
}

/// One level of a cube map: its face size and RGBA texels (alpha 1), face by face.
struct CubeLevel {
    size: usize,
    rgba: Vec<f32>,
}

/// A cube map's texel format and supercompression, as read from its header.
#[derive(Clone, Copy)]
struct Encoding {
    format: KtxFormat,
    zstd: bool,
}

/// The levels of an rgb9e5 + Zstandard or an RGBA16F KTX2 cube map, level 0 first.
fn read(ktx: &[u8]) -> (Encoding, Vec<CubeLevel>) {
    assert_eq!(&ktx[..12], &IDENTIFIER, "not a KTX2 file");
    let encoding = match (u32_at(ktx, 12), u32_at(ktx, 44)) {
        (123, 2) => Encoding { format: KtxFormat::Rgb9e5, zstd: true },
        (97, 0) => Encoding { format: KtxFormat::Rgba16f, zstd: false },
        other => panic!("(vkFormat, supercompression) {other:?}: not rgb9e5 + Zstandard or RGBA16F"),
    };
    assert_eq!(u32_at(ktx, 36), 6, "not a cube map");
    let base = u32_at(ktx, 20) as usize;
    let texel = encoding.format.texel_bytes();
    let levels = (0..u32_at(ktx, 40) as usize)
        .map(|k| {
            let (offset, len, raw) = (u64_at(ktx, 80 + 24 * k), u64_at(ktx, 88 + 24 * k), u64_at(ktx, 96 + 24 * k));
            let bytes = if encoding.zstd {
                zstd::bulk::decompress(&ktx[offset..offset + len], raw).expect("a Zstandard level")
            } else {
                ktx[offset..offset + len].to_vec()
            };
            let size = (base >> k).max(1);
            assert_eq!(bytes.len(), 6 * size * size * texel, "level {k}");
            let rgba = bytes
                .chunks_exact(texel)
                .flat_map(|t| match encoding.format {
                    KtxFormat::Rgb9e5 => {
                        let [r, g, b] = decode_rgb9e5(u32::from_le_bytes([t[0], t[1], t[2], t[3]]));
                        [r, g, b, 1.0]
                    }
                    _ => [0, 1, 2, 3].map(|c| half::f16::from_le_bytes([t[2 * c], t[2 * c + 1]]).to_f32()),
                })
                .collect();
            CubeLevel { size, rgba }
        })
        .collect();
    (encoding, levels)
}

/// `levels` as the bake writes them, in `encoding`.
fn write(encoding: Encoding, levels: &[CubeLevel]) -> Vec<u8> {
    let lv: Vec<Level> = levels.iter().map(|l| Level { width: l.size, height: l.size, rgba: &l.rgba }).collect();
    let scheme = if encoding.zstd { KtxSupercompression::Zstd } else { KtxSupercompression::None };
    encode_with(&lv, 6, encoding.format, Compression { scheme, ..Compression::default() }).expect("a valid cube map")
}

/// Faces `a` and `b` (0..6: +X, -X, +Y, -Y, +Z, -Z) exchanged in every level: a writer that got
/// the face order wrong.
pub fn swap_faces(ktx: &[u8], a: usize, b: usize) -> Vec<u8> {
    let (encoding, mut levels) = read(ktx);
    for l in &mut levels {
        let face = l.size * l.size * 4;
        let (lo, hi) = (a.min(b), a.max(b));
        let (first, second) = l.rgba.split_at_mut(hi * face);
        first[lo * face..(lo + 1) * face].swap_with_slice(&mut second[..face]);
    }
    write(encoding, &levels)
}

/// Every texel times `factor`: e.g. irradiance E written where the engine expects E / pi.
pub fn scale_rgb(ktx: &[u8], factor: f32) -> Vec<u8> {
    let (encoding, mut levels) = read(ktx);
    for l in &mut levels {
        for t in l.rgba.chunks_exact_mut(4) {
            t[..3].iter_mut().for_each(|c| *c *= factor);
        }
    }
    write(encoding, &levels)
}

#[test]
fn reading_and_writing_again_keeps_every_byte() {
    let rgba: Vec<f32> =
        (0..6 * 4 * 4).flat_map(|i| [i as f32 * 0.37, 1.0 / (1.0 + i as f32), 200.0 + i as f32, 1.0]).collect();
    let small: Vec<f32> = (0..6 * 4).flat_map(|i| [i as f32, 0.5, 0.25, 1.0]).collect();
    let tiny = vec![3.0f32; 6 * 4];
    let levels = [CubeLevel { size: 4, rgba }, CubeLevel { size: 2, rgba: small }, CubeLevel { size: 1, rgba: tiny }];
    for encoding in
        [Encoding { format: KtxFormat::Rgb9e5, zstd: true }, Encoding { format: KtxFormat::Rgba16f, zstd: false }]
    {
        let file = write(encoding, &levels);
        let again = |f: &[u8]| {
            let (e, l) = read(f);
            write(e, &l)
        };
        assert_eq!(again(&file), file);
        // Swapping twice is no swap; the swap moves whole faces.
        assert_eq!(swap_faces(&swap_faces(&file, 4, 5), 5, 4), file);
        let swapped = read(&swap_faces(&file, 1, 4)).1;
        let back = read(&file).1;
        assert_eq!(swapped[0].rgba[16 * 4..32 * 4], back[0].rgba[64 * 4..80 * 4]);
        assert_eq!(swapped[2].rgba[4 * 4..5 * 4], back[2].rgba[4..8]);
    }
}
