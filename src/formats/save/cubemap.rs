//! How `Save` writes a cube map and a mip chain. As `.exr`, `.pfm`, `.hdr` or `.png` (exposure,
//! sRGB, 8-bit: to look at): a cube map as ONE horizontal strip of its six faces in storage order
//! (6S x S, +X at the left, `Cubemap::to_strip`); a chain as one such strip per level,
//! `Save(path: "spec_{level}.exr")` writing `spec_0.exr`, `spec_1.exr`, ... (the path must
//! contain `{level}`; [`save_levels`]). As `.ktx2` (any `KtxFormat`, alpha 1): a cube map is one
//! cube texture (faceCount 6) of one level, and a chain ONE cube texture whose levelCount is the
//! chain's length (`{level}` not needed); `formats::ktx2`. As `.ktx` (KTX 1.1 for Filament,
//! `formats::ktx1`): the same cube texture. A chain as `.env`: Babylon.js's prefiltered
//! environment (`formats::babylon_env`, every level down to 1 x 1, with `Save`'s `sh` as its
//! irradiance). A chain as `.gltf`: a glTF asset whose `EXT_lights_image_based` light it is, written
//! by `Save` itself with its images (`formats::gltf_ibl`).

use super::image::encode_image;
use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::formats::babylon_env::{self, EnvIrradiance};
use crate::values::{Cubemap, MipChain, CUBEMAP, MIP_CHAIN};

/// Registers the savers of cube maps and mip chains.
pub fn register(r: &mut Registry) {
    r.register_saver(&CUBEMAP, &["exr", "pfm", "hdr", "png", "ktx2", "ktx"], save);
    r.register_saver(&MIP_CHAIN, &["exr", "pfm", "hdr", "png", "ktx2", "ktx", "env", "gltf"], save_chain_level0);
}

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<Cubemap>().ok_or("not a cube map")?;
    if o.ext == "ktx2" || o.ext == "ktx" {
        return encode_ktx(std::slice::from_ref(c), o);
    }
    encode_image(&c.to_strip(), o)
}

/// Only used when a chain reaches a type's encoder directly: `Save` writes every level itself
/// (see [`save_levels`]).
fn save_chain_level0(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<MipChain>().ok_or("not a mip chain")?;
    if o.ext == "ktx2" || o.ext == "ktx" {
        return encode_ktx(&c.levels, o);
    }
    if o.ext == "env" {
        let EnvIrradiance(polynomial) = o.get_or_default();
        let (bytes, _) = babylon_env::encode(&c.levels, polynomial.as_ref(), babylon_env::LOD_GENERATION_SCALE, true)?;
        return Ok(bytes);
    }
    if o.ext == "gltf" {
        return Err("a .gltf is written with its images and irradiance by Save (its sh input)".into());
    }
    let first = c.levels.first().ok_or("an empty mip chain")?;
    encode_image(&first.to_strip(), o)
}

/// Cube maps as the levels of one `.ktx2` (or, for `o.ext == "ktx"`, KTX 1.1 `.ktx`) cube texture
/// (faceCount 6, +X -X +Y -Y +Z -Z, alpha 1); level k must be of size max(1, size >> k), else an
/// error.
pub fn encode_ktx(levels: &[Cubemap], o: &SaveOptions) -> Result<Vec<u8>, String> {
    if o.ext == "ktx" {
        let rgba: Vec<Vec<f32>> = levels.iter().map(|c| crate::formats::ktx2::rgb_to_rgba(&c.data)).collect();
        let levels: Vec<_> = levels
            .iter()
            .zip(&rgba)
            .map(|(c, rgba)| crate::formats::ktx2::Level { width: c.size, height: c.size, rgba })
            .collect();
        return crate::formats::ktx1::encode(&levels, 6, o.get_or_default(), &o.get_or_default())
            .map_err(|e| e.to_string());
    }
    // Straight from the RGB levels: a 4096 chain's RGBA copy would be 2.1 GB.
    let levels: Vec<_> =
        levels.iter().map(|c| crate::formats::ktx2::RgbLevel { width: c.size, height: c.size, rgb: &c.data }).collect();
    crate::formats::ktx2::encode_rgb_with(&levels, 6, o.get_or_default(), o.get_or_default()).map_err(|e| e.to_string())
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
