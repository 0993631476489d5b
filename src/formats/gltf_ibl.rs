//! glTF 2.0 assets that carry an image-based light (write only): the vendor extension
//! `EXT_lights_image_based` (KhronosGroup/glTF, `extensions/2.0/Vendor/EXT_lights_image_based/
//! README.md`), which Babylon.js's glTF loader implements (`@babylonjs/loaders`,
//! `glTF/2.0/Extensions/EXT_lights_image_based.ts`). One `.gltf` (JSON) and its PNG images
//! beside it:
//!
//! - `extensionsUsed: ["EXT_lights_image_based"]` and, at the root, `extensions.
//!   EXT_lights_image_based.lights`: one light with `intensity` 1 (written: Babylon's loader
//!   scales the SH by it unguarded, so a missing one would make them NaN), no `rotation`
//!   (identity), `specularImageSize` (level 0's face size) and `specularImages` (per level, six
//!   image indices, faces +X -X +Y -Y +Z -Z), and `irradianceCoefficients` ([`irradiance_coefficients`]);
//! - `scenes[0].extensions.EXT_lights_image_based: {"light": 0}` and `scene: 0`: the scene that
//!   uses it (no nodes: the asset is the light);
//! - `images`: one per face and level, `{uri, mimeType: "image/png"}`, the PNG next to the
//!   `.gltf` (`{stem}_specular_{level}_{face}.png`, `face` one of [`FACES`]): 8-bit RGBA in RGBD
//!   (`formats::rgbd`; the README: "PNG's - assumed to be HDR images packed in RGBD format"),
//!   rows as Babylon uploads them (bottom row first, as in a `.env`: the same
//!   `UploadRadianceLevelsAsync`).
//!
//! The levels: the README asks for power-of-two square faces, each level half the last, the last
//! "sufficient size to represent the maximally-blurred radiance map (say, 16x16) corresponding to
//! roughness=1"; Babylon reads level `lod = s log2(size alphaG)` with `s = (levels - 1) /
//! log2(size)` (the loader's `lodGenerationScale`), so the last level stands for `alphaG = 1`.
//! What each level must hold is the preset's business (`ibl_presets::gltf`).

use serde_json::{json, Value as Json};

use super::babylon_env::{band, A};
use super::rgbd;
use crate::values::Cubemap;

/// The extension's name.
pub const EXTENSION: &str = "EXT_lights_image_based";

/// The faces' names in image file names, in the extension's order.
pub const FACES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];

/// Babylon's real SH basis carries the Condon-Shortley phase: its `l1_1`, `l11`, `l2_1` and `l21`
/// functions (`SH3ylmBasisConstants`, `Maths/sphericalPolynomial.ts`) are hdrflow's negated.
pub const CONDON_SHORTLEY: [f64; 9] = [1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0];

/// The extension's `irradianceCoefficients` from the 9 orthonormal radiance SH `L_lm` (hdrflow's
/// real basis, index `l^2 + l + m`; `ShIrradiance`) in the axes the engine evaluates them in: the
/// SH of the irradiance `E` (`A_l L_lm`, `A_l = pi, 2 pi / 3, pi / 4`) in Babylon's basis (its
/// order `l00, l1_1, l10, l11, l2_2, l2_1, l20, l21, l22` is hdrflow's index order; signs
/// [`CONDON_SHORTLEY`]). Babylon's loader reads them with `SphericalHarmonics.FromArray`, scales
/// them by `intensity` and `1 / pi` (`convertIrradianceToLambertianRadiance`) and its shader
/// evaluates them at the normal: `E(n) / pi`, as its `.env` polynomial gives.
pub fn irradiance_coefficients(l: &[[f64; 3]]) -> Result<[[f64; 3]; 9], String> {
    if l.len() < 9 {
        return Err(format!("irradianceCoefficients need the 9 SH of order 2, got {}", l.len()));
    }
    let pi = std::f64::consts::PI;
    Ok(std::array::from_fn(|i| l[i].map(|v| pi * A[band(i)] * CONDON_SHORTLEY[i] * v)))
}

/// The file name of face `f` of level `level` of the asset `stem`.
pub fn image_name(stem: &str, level: usize, f: usize) -> String {
    format!("{stem}_specular_{level}_{}.png", FACES[f])
}

/// `name` as a relative URI reference: every byte but the unreserved ones percent-encoded.
fn uri(name: &str) -> String {
    name.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The glTF document of the asset `stem` whose light has `levels` levels of faces from `size`
/// down, and the irradiance `coefficients`.
pub fn document(stem: &str, size: usize, levels: usize, coefficients: &[[f64; 3]; 9]) -> Json {
    let images: Vec<Json> = (0..levels)
        .flat_map(|k| (0..6).map(move |f| json!({ "uri": uri(&image_name(stem, k, f)), "mimeType": "image/png" })))
        .collect();
    let specular: Vec<Vec<usize>> = (0..levels).map(|k| (6 * k..6 * k + 6).collect()).collect();
    json!({
        "asset": { "version": "2.0", "generator": concat!("hdrflow ", env!("CARGO_PKG_VERSION")) },
        "extensionsUsed": [EXTENSION],
        "extensions": { EXTENSION: { "lights": [{
            "name": stem,
            "intensity": 1.0,
            "irradianceCoefficients": coefficients.to_vec(),
            "specularImageSize": size,
            "specularImages": specular,
        }] } },
        "images": images,
        "scene": 0,
        "scenes": [{ "name": stem, "extensions": { EXTENSION: { "light": 0 } } }],
    })
}

/// Files to write: each relative path and its bytes.
pub type Files = Vec<(String, Vec<u8>)>;

/// The asset at `path` (relative, ending in `.gltf`): the `.gltf` first, then every level's six
/// face PNGs beside it; and how many texels were beyond RGBD's range (clamped). `levels`: level k
/// of faces of `size >> k`, `size` a power of two.
pub fn encode(levels: &[Cubemap], coefficients: &[[f64; 3]; 9], path: &str) -> Result<(Files, usize), String> {
    let size = levels.first().ok_or("a glTF light needs at least one level")?.size;
    if !size.is_power_of_two() {
        return Err(format!("{EXTENSION} needs power-of-two faces (its README), got {size}"));
    }
    for (k, c) in levels.iter().enumerate() {
        if c.size != size >> k || c.size == 0 {
            return Err(format!("level {k} has faces of {}, not {} (each level halves the last)", c.size, size >> k));
        }
    }
    let (folder, file) = path.rsplit_once('/').map_or(("", path), |(d, f)| (d, f));
    let stem = file.strip_suffix(".gltf").ok_or_else(|| format!("{path}: not a .gltf path"))?;
    let doc = document(stem, size, levels.len(), coefficients);
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    let (pngs, overflow) = rgbd::chain_pngs(levels, true)?;
    let beside = |name: String| if folder.is_empty() { name } else { format!("{folder}/{name}") };
    let mut files = vec![(path.to_string(), text.into_bytes())];
    for (i, png) in pngs.into_iter().enumerate() {
        files.push((beside(image_name(stem, i / 6, i % 6)), png));
    }
    Ok((files, overflow))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::babylon_env::Polynomial;
    use crate::maths::ibl::sh::eval_sh;
    use crate::values::ShFrame;

    fn chain(size: usize, levels: usize) -> Vec<Cubemap> {
        (0..levels)
            .map(|k| {
                let mut c = Cubemap::new(size >> k);
                c.data.iter_mut().enumerate().for_each(|(i, v)| *v = 0.1 * (1 + i % 5) as f32);
                c
            })
            .collect()
    }

    /// The document has what the README and Babylon's loader read: the extension used and
    /// declared, one light with intensity 1, its size, N x 6 image indices in order, 9 RGB
    /// coefficients, a scene referring to light 0, and one PNG image per face and level whose
    /// URI is the file written beside the .gltf.
    #[test]
    fn the_document_is_the_extensions_structure() {
        let c = [[0.5, 0.25, 0.125]; 9];
        let (files, overflow) = encode(&chain(64, 3), &c, "out/my sky.gltf").unwrap();
        assert_eq!((files.len(), overflow), (1 + 18, 0));
        let doc: Json = serde_json::from_slice(&files[0].1).unwrap();
        assert_eq!(files[0].0, "out/my sky.gltf");
        assert_eq!(doc["asset"]["version"], "2.0");
        assert_eq!(doc["extensionsUsed"], json!([EXTENSION]));
        assert_eq!(doc["scene"], 0);
        assert_eq!(doc["scenes"][0]["extensions"][EXTENSION]["light"], 0);
        let light = &doc["extensions"][EXTENSION]["lights"][0];
        assert_eq!(light["intensity"], 1.0);
        assert!(light.get("rotation").is_none());
        assert_eq!(light["specularImageSize"], 64);
        assert_eq!(light["irradianceCoefficients"], json!(c.to_vec()));
        let spec = light["specularImages"].as_array().unwrap();
        assert_eq!(spec.len(), 3);
        assert_eq!(spec[1], json!([6, 7, 8, 9, 10, 11]));
        let images = doc["images"].as_array().unwrap();
        assert_eq!(images.len(), 18);
        assert_eq!(images[7]["uri"], "my%20sky_specular_1_nx.png");
        assert_eq!(images[7]["mimeType"], "image/png");
        assert_eq!(files[8].0, "out/my sky_specular_1_nx.png");
        for (i, (_, png)) in files[1..].iter().enumerate() {
            let img = image::load_from_memory(png).unwrap();
            assert_eq!(img.color(), image::ColorType::Rgba8, "image {i}: RGBD is 4-channel");
            assert_eq!(img.width() as usize, 64 >> (i / 6), "image {i}");
        }
        assert!(encode(&chain(64, 3)[1..], &c, "a.gltf").is_ok());
        assert!(encode(&[Cubemap::new(12)], &c, "a.gltf").unwrap_err().contains("power-of-two"));
        let mut bad = chain(64, 3);
        bad.swap(1, 2);
        assert!(encode(&bad, &c, "a.gltf").unwrap_err().contains("level 1"));
        assert!(encode(&chain(8, 1), &c, "a.png").is_err());
    }

    /// What Babylon makes of the coefficients (`FromArray`, times 1 / pi, its basis with the
    /// Condon-Shortley phase) is `E / pi`, as its `.env` polynomial gives; a constant radiance 1
    /// gives `l00 = pi 2 sqrt(pi)`.
    #[test]
    fn babylon_reads_the_coefficients_as_e_over_pi() {
        let l: Vec<[f64; 3]> = (0..9).map(|i| [0.3 + 0.1 * i as f64, -0.2 * i as f64, (i as f64).cos()]).collect();
        let c = irradiance_coefficients(&l).unwrap();
        let poly = Polynomial::from_sh(&l).unwrap();
        for d in [[0.0, 1.0, 0.0], [0.6, 0.0, -0.8], [0.48, 0.6, 0.64], [-0.36, -0.48, 0.8]] {
            let y = eval_sh(ShFrame::World, 2, d);
            let babylon: [f64; 3] =
                [0, 1, 2].map(|k| (0..9).map(|i| c[i][k] / std::f64::consts::PI * CONDON_SHORTLEY[i] * y[i]).sum());
            let want = poly.irradiance(d);
            for k in 0..3 {
                assert!((babylon[k] - want[k]).abs() < 2e-5, "{d:?}: {babylon:?} vs {want:?}");
            }
        }
        let mut one = vec![[0.0; 3]; 9];
        one[0] = [2.0 * std::f64::consts::PI.sqrt(); 3];
        let c = irradiance_coefficients(&one).unwrap();
        assert!((c[0][0] - 2.0 * std::f64::consts::PI.powf(1.5)).abs() < 1e-12);
        assert!(irradiance_coefficients(&l[..4]).is_err());
    }
}
