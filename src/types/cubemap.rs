//! `cube map` ([`Cubemap`]) and `mip chain` ([`MipChain`]): six square RGB faces in the order
//! +X, -X, +Y, -Y, +Z, -Z (axes in `geometry::cubemap`), and a list of them.
//!
//! Cache payloads: a cube map is its face size then its 18 S^2 f32 values; a chain is its level
//! count, then per level its roughness (f64) and its cube map. Saved as `.exr`, `.pfm`, `.hdr` or
//! `.png` (exposure, sRGB, 8-bit: to look at):
//! a cube map as ONE horizontal strip of its six faces in storage order (6S x S, +X at the left);
//! a chain as one such strip per level, `Save(path: "spec_{level}.exr")` writing `spec_0.exr`,
//! `spec_1.exr`, ... (the path must contain `{level}`). As `.ktx2` (any `KtxFormat`, alpha 1): a
//! cube map is one cube texture (faceCount 6) of one level, and a chain ONE cube texture whose
//! levelCount is the chain's length (`{level}` not needed); `formats::ktx2`. As `.ktx` (KTX 1.1 for
//! Filament, `formats::ktx1`): the same cube texture.

use crate::data::{Cubemap, MipChain};
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{SaveOptions, TypeSpec, Value, ValueData, ValueType};
use crate::types::image::encode_image;

pub static CUBEMAP: TypeSpec = TypeSpec {
    name: "cube map",
    doc: "six square RGB faces +X, -X, +Y, -Y, +Z, -Z (OpenGL/KTX order, hdrflow's axes); saved as a 6S x S strip or a .ktx2 cube",
    decode,
    save_extensions: &["exr", "pfm", "hdr", "png", "ktx2", "ktx"],
    save: Some(save),
};

pub static MIP_CHAIN: TypeSpec = TypeSpec {
    name: "mip chain",
    doc: "cube maps, level k of face size max(1, size >> k), each with its roughness; saved one strip per level (`{level}` in the path), or as one .ktx2",
    decode: decode_chain,
    save_extensions: &["exr", "pfm", "hdr", "png", "ktx2", "ktx"],
    save: Some(save_chain_level0),
};

/// The largest face size a cache entry may claim (2^14: 6 x 2^28 texels is above the engine's
/// image limit; this only bounds the arithmetic before the length is checked).
const MAX_SIZE: usize = 1 << 14;
/// The most levels a chain entry may claim.
const MAX_LEVELS: usize = 64;

impl ValueData for Cubemap {
    fn value_type(&self) -> ValueType {
        ValueType(&CUBEMAP)
    }
    fn approx_bytes(&self) -> usize {
        self.data.len() * 4
    }
    fn summary(&self) -> String {
        let n = self.texel_count().max(1) as f64;
        let mean: Vec<String> = (0..3)
            .map(|k| format!("{:.6}", self.data.iter().skip(k).step_by(3).map(|&v| v as f64).sum::<f64>() / n))
            .collect();
        format!("cube map {0}x{0} x 6, texel means R G B: {1}", self.size, mean.join(" "))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.size as u64);
        w.f32s(&self.data);
    }
}

fn read_cube(r: &mut Reader) -> Result<Cubemap, String> {
    let size = r.usize()?;
    if size == 0 || size > MAX_SIZE {
        return Err(format!("cube map face size {size} is out of range"));
    }
    let data = r.f32s()?;
    if data.len() != 18 * size * size {
        return Err("cube map size does not match its data".into());
    }
    Ok(Cubemap { size, data })
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let c = read_cube(&mut r)?;
    r.finish()?;
    Ok(Value::new(c))
}

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<Cubemap>().ok_or("not a cube map")?;
    if o.ext == "ktx2" || o.ext == "ktx" {
        return encode_ktx(std::slice::from_ref(c), o);
    }
    encode_image(&c.to_strip(), o)
}

impl ValueData for MipChain {
    fn value_type(&self) -> ValueType {
        ValueType(&MIP_CHAIN)
    }
    fn approx_bytes(&self) -> usize {
        self.levels.iter().map(|c| c.data.len() * 4).sum()
    }
    fn summary(&self) -> String {
        let sizes: Vec<String> = self.levels.iter().map(|c| c.size.to_string()).collect();
        format!("mip chain of {} cube maps, face sizes {}", self.levels.len(), sizes.join(" "))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        Writer(out).u64(self.levels.len() as u64);
        for (c, r) in self.levels.iter().zip(&self.roughness) {
            Writer(out).f64(*r);
            c.encode(out);
        }
    }
}

fn decode_chain(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let n = r.usize()?;
    if n > MAX_LEVELS {
        return Err(format!("{n} mip levels is out of range"));
    }
    let mut chain = MipChain { levels: Vec::with_capacity(n), roughness: Vec::with_capacity(n) };
    for _ in 0..n {
        chain.roughness.push(r.f64()?);
        chain.levels.push(read_cube(&mut r)?);
    }
    r.finish()?;
    Ok(Value::new(chain))
}

/// Only used when a chain reaches a type's encoder directly: `Save` writes every level itself
/// (see [`save_levels`]).
fn save_chain_level0(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<MipChain>().ok_or("not a mip chain")?;
    if o.ext == "ktx2" || o.ext == "ktx" {
        return encode_ktx(&c.levels, o);
    }
    let first = c.levels.first().ok_or("an empty mip chain")?;
    encode_image(&first.to_strip(), o)
}

/// Cube maps as the levels of one `.ktx2` (or, for `o.ext == "ktx"`, KTX 1.1 `.ktx`) cube texture
/// (faceCount 6, +X -X +Y -Y +Z -Z, alpha 1); level k must be of size max(1, size >> k), else an
/// error.
pub fn encode_ktx(levels: &[Cubemap], o: &SaveOptions) -> Result<Vec<u8>, String> {
    let rgba: Vec<Vec<f32>> = levels.iter().map(|c| crate::formats::ktx2::rgb_to_rgba(&c.data)).collect();
    let levels: Vec<_> = levels
        .iter()
        .zip(&rgba)
        .map(|(c, rgba)| crate::formats::ktx2::Level { width: c.size, height: c.size, rgba })
        .collect();
    if o.ext == "ktx" {
        return crate::formats::ktx1::encode(&levels, 6, o.get_or_default(), &o.get_or_default())
            .map_err(|e| e.to_string());
    }
    crate::formats::ktx2::encode_with(&levels, 6, o.get_or_default(), o.get_or_default()).map_err(|e| e.to_string())
}

/// Every level's strip, at `template` with `{level}` replaced by the level number.
pub fn save_levels(chain: &MipChain, template: &str, o: &SaveOptions) -> Result<Vec<(String, Vec<u8>)>, String> {
    chain
        .levels
        .iter()
        .enumerate()
        .map(|(k, c)| Ok((template.replace("{level}", &k.to_string()), encode_image(&c.to_strip(), o)?)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_strip_layout() {
        let mut c = Cubemap::new(2);
        for (i, v) in c.data.iter_mut().enumerate() {
            *v = i as f32;
        }
        let mut bytes = Vec::new();
        c.encode(&mut bytes);
        assert_eq!(decode(&bytes).unwrap().get::<Cubemap>(), Some(&c));
        for cut in [0, 8, bytes.len() - 1] {
            let e = decode(&bytes[..cut]).unwrap_err();
            assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
        }
        let chain = MipChain { levels: vec![c.clone(), Cubemap::new(1)], roughness: vec![0.0, 1.0] };
        let mut bytes = Vec::new();
        chain.encode(&mut bytes);
        assert_eq!(decode_chain(&bytes).unwrap().get::<MipChain>(), Some(&chain));
        let e = decode_chain(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.starts_with("truncated: need"), "{e}");
        // The strip: face f at columns f*S..(f+1)*S, and back.
        let strip = c.to_strip();
        assert_eq!((strip.width, strip.height), (12, 2));
        assert_eq!(strip.rgb(2, 0), c.texel(4));
        assert_eq!(Cubemap::from_strip(&strip), Some(c));
    }
}
