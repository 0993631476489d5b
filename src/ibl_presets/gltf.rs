//! A glTF 2.0 asset carrying the lighting as `EXT_lights_image_based` (the format:
//! `formats::gltf_ibl`), for the engine that implements the extension, Babylon.js's glTF loader
//! (`@babylonjs/loaders`, `glTF/2.0/Extensions/EXT_lights_image_based.ts`), which makes it
//! `scene.environmentTexture` (a `RawCubeTexture` through `updateRGBDAsync`, the path of a `.env`):
//!
//! - World: as `babylon.rs`. The loader sets the cube as the scene's environment, outside the
//!   glTF's root node, so Babylon samples it with its own world direction: in its default
//!   left-handed scene hdrflow's `(X, Y, -Z)`, the map's centre facing +Z, its default camera's
//!   forward (`CubeFrame::MirrorZ`, as the `.env`); the loader's root node turns glTF content by
//!   180 degrees about Y with z negated, so that content sees the map unmirrored, its centre at
//!   the asset's front (+Z). Faces are written bottom row first, as in a `.env`.
//! - Levels: the README's "lowest-resolution mip ... (say, 16x16) corresponding to
//!   roughness=1": faces from the quality's size down to 16 (`Chain::ToSize(16)`, 5 levels from
//!   256). The loader sets `lodGenerationScale = s = (N - 1) / log2(size)` (N levels; 0.5 for 256)
//!   and Babylon's PBR shader reads `lod = s log2(size alphaG)`, `alphaG = roughness^2 + 0.0005`,
//!   so level `l` must hold GGX of `alphaG_l = 2^(l / s) / size`: `roughness = sqrt(alphaG_l)`,
//!   0 at level 0 and exactly 1 at the last (`level_roughness`); levels below the last are black
//!   in Babylon (its loader fills them), which roughness 1 reads at 0.04%.
//! - Irradiance: `irradianceCoefficients`, the SH of the irradiance `E` in Babylon's basis and
//!   world (`formats::gltf_ibl::irradiance_coefficients`, from 9 SH in its axes: `ShIrradiance(frame:
//!   Paper)`, as for the `.env`); the loader scales them by `1 / pi` and its shader evaluates `E / pi`.
//! - Sizes: as the Babylon preset's (128, 256, 512, power of two). Samples: 1024, 4096, 8192, four
//!   times the other presets' by default: the chain stops at 16, so on a 256 cube level 3 (faces
//!   of 32, roughness 0.5) is sampled rather than summed exactly (`PrefilterSpecular`'s
//!   `rough_exact` stays under 2^26 texel pairs), and at 1024 samples its noise is 0.57% RMS on
//!   Babylon's roughness-0.5 sphere (0.26% at 4096; tests/gltf_render.rs, the book's page).
//!   Texels: RGBD 8-bit PNG (up to 255; brighter ones are clamped and counted in a warning).
//!
//! Checked in Babylon.js itself (tests/gltf_render.rs): spheres of roughness 0 to 1 and a
//! diffuse one against Babylon's shader formula fed exact values, each classic mistake failing;
//! the asset is valid for the Khronos glTF validator.

use std::path::Path;

use super::{Chain, Engine, Preset, Quality, SpecSize};
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

/// The smallest faces of the chain (the README's "say, 16x16").
pub const SMALLEST: usize = 16;

/// The loader's `lodGenerationScale` for `levels` levels from faces of `size`.
pub fn lod_scale(size: usize, levels: usize) -> f64 {
    (levels.max(1) - 1) as f64 / (size.max(2) as f64).log2()
}

/// The roughness of each level of a chain of faces of `size` and `levels` levels (see the
/// module doc): `sqrt(2^(l / s) / size)`, 0 at level 0, 1 at the last.
pub fn level_roughness(size: usize, levels: usize) -> Vec<f64> {
    let s = lod_scale(size, levels);
    (0..levels).map(|l| if l == 0 { 0.0 } else { (2f64.powf(l as f64 / s) / size as f64).sqrt().min(1.0) }).collect()
}

/// Whether a glTF bake of the map named `map` may write into `dir`, which holds an earlier gltf
/// bake's notes (`ours`) or not: a `.gltf` or `.glb` there other than `{map}.gltf`, or that file
/// without such notes, is another asset, whose files the bake's would mix with or replace:
/// refused (the message without `error: `).
pub fn check_assets(dir: &Path, map: &str, ours: bool) -> Result<(), String> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
    let mine = format!("{map}.gltf");
    let mut names: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| {
            let lower = n.to_ascii_lowercase();
            lower.ends_with(".gltf") || lower.ends_with(".glb")
        })
        .collect();
    names.sort();
    let other = names.iter().find(|n| **n != mine || !ours);
    match other {
        None => Ok(()),
        Some(n) => Err(format!(
            "{} holds a glTF asset, {n}, {}: a bake for gltf writes {mine} and its images there, which would {} \
             that asset; write it elsewhere with --out (the default, out/bake/gltf, holds only gltf bakes) or move it",
            dir.display(),
            if *n == mine { "that no gltf bake wrote (no README.txt of one)" } else { "not this bake's" },
            if *n == mine { "replace" } else { "mix with" },
        )),
    }
}

pub const PRESET: Preset = Preset {
    engine: Engine::Gltf,
    name: "gltf",
    loads: "a glTF 2.0 asset (.gltf) whose scene uses an EXT_lights_image_based light: RGBD PNG faces of each level down to 16 x 16 and 9 irradiance SH; Babylon.js's glTF loader makes it scene.environmentTexture",
    world: "Babylon's: left-handed, +Y up, +Z forward: hdrflow's (X, Y, -Z); glTF content loaded with it sees the map's centre at the asset's front (+Z)",
    cube_frame: Some(CubeFrame::MirrorZ),
    roughness_map: Some(RoughnessMap::List),
    level_roughness: Some(level_roughness),
    lod: "lod = s log2(size (r^2 + 0.0005)), s = (levels - 1) / log2(size): 0.5 for 256",
    irradiance: "irradianceCoefficients: the SH of E in Babylon's basis and world (its shader evaluates E / pi)",
    files: "{name}.gltf, {name}_sun.json",
    texel_formats: "RGBD 8-bit PNG (values up to 255), {name}_specular_LEVEL_FACE.png beside the .gltf",
    centre_yaw: 0.0,
    tools: &[],
    quality: Some([
        Quality { spec_size: SpecSize::Fixed(128), samples: 1024, irradiance_size: None },
        Quality { spec_size: SpecSize::Fixed(256), samples: 4096, irradiance_size: None },
        Quality { spec_size: SpecSize::Fixed(512), samples: 8192, irradiance_size: None },
    ]),
    chain: Chain::ToSize(SMALLEST),
    size_rule: Some("EXT_lights_image_based needs power-of-two faces (its README)"),
    check_assets: Some(check_assets),
    pipeline: include_str!("../../graphs/bake/gltf.ron"),
    loading_code: r#"// Babylon.js (@babylonjs/core 9 and @babylonjs/loaders 9), in an async module with your `scene`: the glTF
// loader implements EXT_lights_image_based and sets scene.environmentTexture.
import { AppendSceneAsync } from '@babylonjs/core';
import '@babylonjs/loaders/glTF';
const gltfUrl = '{file:save_gltf}';
await AppendSceneAsync(gltfUrl, scene);
// The images hold linear RGBD (the extension's README); the loader's cube texture keeps Babylon's default
// gammaSpace (true), which would raise the reflections to the power 2.2:
scene.environmentTexture.gammaSpace = false;
// The map as the background too (level 0):
scene.createDefaultSkybox(scene.environmentTexture, true, 1000, 0);
"#,
    sun_code: super::babylon::SUN_CODE,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The loader's lodGenerationScale on a 256 chain of 5 levels is 0.5, and the shader reads
    /// level l back where the chain put alphaG_l (without the minimum variance).
    #[test]
    fn level_roughness_is_what_babylons_shader_reads_at_each_level() {
        let levels = Chain::ToSize(SMALLEST).levels(256);
        assert_eq!(levels, 5);
        assert_eq!(lod_scale(256, levels), 0.5);
        let r = level_roughness(256, levels);
        assert_eq!(r, vec![0.0, 0.125, 0.25, 0.5, 1.0]);
        for (size, levels) in [(128, 4), (512, 6), (16, 5)] {
            let s = lod_scale(size, levels);
            let r = level_roughness(size, levels);
            for (l, r) in r.iter().enumerate().skip(1) {
                let lod = s * (size as f64 * r * r).log2();
                assert!((lod - l as f64).abs() < 1e-9, "{size}, {l}: {lod}");
            }
            assert_eq!(r[levels - 1], 1.0);
        }
        assert_eq!(level_roughness(1, 1), vec![0.0]);
    }

    /// Another asset in the folder is refused; an earlier bake of the same map is not.
    #[test]
    fn another_asset_in_the_folder_is_refused() {
        let dir = std::env::temp_dir().join(format!("hdrflow-gltf-assets-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        assert!(check_assets(&dir, "sky", false).is_ok());
        assert!(check_assets(&dir.join("missing"), "sky", false).is_ok());
        std::fs::write(dir.join("sky.gltf"), "{}").unwrap();
        assert!(check_assets(&dir, "sky", true).is_ok());
        let e = check_assets(&dir, "sky", false).unwrap_err();
        assert!(e.contains("sky.gltf, that no gltf bake wrote") && e.contains("--out"), "{e}");
        std::fs::write(dir.join("Model.GLB"), "").unwrap();
        let e = check_assets(&dir, "sky", true).unwrap_err();
        assert!(e.contains("Model.GLB, not this bake's") && e.contains("mix with"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
