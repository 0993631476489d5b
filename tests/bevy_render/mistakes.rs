//! The z mirror the Bevy bake needs, and the deliberate mistakes the test must catch, made on the
//! files a correct bake wrote (or, for the roughness map, baked wrongly with hdrflow's library).

use hdrflow::formats::ktx2::{encode, rgb_to_rgba, KtxFormat, Level};
use hdrflow::maths::ggx::{points, prefilter_level_fis, pyramid, LobeSequence};
use hdrflow::maths::resample::{to_cube, LatLongSource};
use hdrflow::maths::specular_lobe::SpecularBrdf;
use hdrflow::values::Image;

/// The lat-long map mirrored in z, `L'(x, y, z) = L(x, y, -z)`: phi -> pi - phi, which maps
/// column x to column `(W / 2 - 1 - x) mod W` exactly (W even). Bevy reads its cube maps at
/// `(x, y, -z)`, so a cube made from this map shows Bevy the map itself.
pub fn mirror_z(env: &Image) -> Image {
    let (w, h, c) = (env.width, env.height, env.channels);
    assert!(w % 2 == 0, "an exact z mirror needs an even width, not {w}");
    let mut out = env.clone();
    for y in 0..h {
        for x in 0..w {
            let src = (w / 2 + w - 1 - x) % w;
            out.data[(y * w + x) * c..(y * w + x + 1) * c]
                .copy_from_slice(&env.data[(y * w + src) * c..(y * w + src + 1) * c]);
        }
    }
    out
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn u64_at(b: &[u8], at: usize) -> usize {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes")) as usize
}

/// (byte offset, byte length) of every level of an uncompressed KTX2 cube map (header and level
/// index: KTX 2.0 specification, sections 3.1-3.9).
fn levels(ktx: &[u8]) -> Vec<(usize, usize)> {
    assert_eq!(&ktx[..12], &hdrflow::formats::ktx2::IDENTIFIER, "not a KTX2 file");
    assert_eq!(u32_at(ktx, 36), 6, "not a cube map");
    assert_eq!(u32_at(ktx, 44), 0, "supercompressed: the test edits uncompressed files only");
    (0..u32_at(ktx, 40) as usize).map(|k| (u64_at(ktx, 80 + 24 * k), u64_at(ktx, 88 + 24 * k))).collect()
}

/// Faces `a` and `b` exchanged in every level (a writer that got the face order wrong).
pub fn swap_faces(ktx: &[u8], a: usize, b: usize) -> Vec<u8> {
    let mut out = ktx.to_vec();
    for (offset, len) in levels(ktx) {
        let face = len / 6;
        let (pa, pb) = (offset + a * face, offset + b * face);
        out[pa..pa + face].copy_from_slice(&ktx[pb..pb + face]);
        out[pb..pb + face].copy_from_slice(&ktx[pa..pa + face]);
    }
    out
}

/// RGB of every texel of an RGBA16F file times `factor` (alpha kept): e.g. irradiance E written
/// where Bevy expects E / pi.
pub fn scale_rgb(ktx: &[u8], factor: f32) -> Vec<u8> {
    assert_eq!(u32_at(ktx, 12), 97, "not VK_FORMAT_R16G16B16A16_SFLOAT");
    let mut out = ktx.to_vec();
    for (offset, len) in levels(ktx) {
        for texel in out[offset..offset + len].chunks_exact_mut(8) {
            for ch in texel[..6].chunks_exact_mut(2) {
                let v = half::f16::from_le_bytes([ch[0], ch[1]]).to_f32() * factor;
                ch.copy_from_slice(&half::f16::from_f32(v).to_le_bytes());
            }
        }
    }
    out
}

/// The specular chain of `env` (face `size`, `levels` levels, 1024 Sobol samples as the pipeline)
/// with level k filtered at roughness `roughness(k)`, as RGBA16F KTX2.
pub fn specular_chain(env: &Image, size: usize, levels: usize, roughness: impl Fn(usize) -> f64) -> Vec<u8> {
    let src = to_cube(&LatLongSource::new(env), size);
    let pyr = pyramid(&src);
    let pts = points(LobeSequence::Sobol, 1024);
    let rgba: Vec<Vec<f32>> = (0..levels)
        .map(|k| {
            let s = (size >> k).max(1);
            let level =
                if k == 0 { src.clone() } else { prefilter_level_fis(&pyr, s, roughness(k), &pts, SpecularBrdf::Ggx) };
            rgb_to_rgba(&level.data)
        })
        .collect();
    let lv: Vec<Level> = rgba
        .iter()
        .enumerate()
        .map(|(k, d)| Level { width: (size >> k).max(1), height: (size >> k).max(1), rgba: d })
        .collect();
    encode(&lv, 6, KtxFormat::Rgba16f).expect("a valid chain")
}

/// Filament's roughness-to-level map, lod = r (2 - r) (N - 1) (cmgen), solved for level k's r: what
/// a chain made for Filament holds, read by Bevy, which expects r = k / (N - 1).
pub fn filament_roughness(k: usize, levels: usize) -> f64 {
    1.0 - (1.0 - k as f64 / (levels - 1) as f64).sqrt()
}
