//! Babylon.js (`BabylonJS/Babylon.js`, `@babylonjs/core`), a `.env` as its own tools write it
//! (`EnvironmentTextureTools.CreateEnvTextureAsync`, `packages/dev/core/src/Misc/
//! environmentTextureTools.ts`; the format: `formats::babylon_env`):
//!
//! - World: left-handed, +Y up, +Z forward (Babylon's default; `scene.useRightHandedSystem`
//!   negates z and sets `REFLECTIONMAP_OPPOSITEZ`, which negates it back in the lookup). Its
//!   `(x, y, z)` is hdrflow's `(X, Y, -Z)`, so the map's centre faces Babylon's default camera
//!   (+Z). The cube is sampled with that direction: `CubeFrame::MirrorZ`, as Bevy's. Each face's
//!   PNG is written bottom row first: Babylon uploads the images with `invertY`.
//! - Levels: every level down to 1 x 1 (`6 (log2(width) + 1)` images, its loader refuses any
//!   other count). Level `l` holds what its own prefiltering (`HDRFiltering`,
//!   `Materials/Textures/Filtering/hdrFiltering.ts`) puts there: GGX of `alphaG = 2^(l / 0.8) /
//!   width` (0 at level 0), weighted by `n.l`; the PBR shader reads `lod = 0.8 log2(width
//!   alphaG)` with `alphaG = roughness^2 + 0.0005` (`getLodFromAlphaG`, `lodGenerationScale`
//!   0.8, offset 0). hdrflow's levels take `roughness = sqrt(alphaG)`, capped at 1: on a 256 cube
//!   levels 7 and 8 (alphaG 1.7 and 4) hold roughness 1, and only roughness above 0.92 reads
//!   level 7 (`level_roughness`).
//! - Irradiance: Babylon's spherical polynomial, from which its shader evaluates `E / pi` at the
//!   normal in its world (`formats::babylon_env::Polynomial`), made from 9 SH in its axes
//!   (`ShIrradiance(frame: Paper)`, whose axes are `(X, Y, -Z)`).
//! - Sizes: Babylon writes every level of whatever cube it is given (`CreateEnvTextureAsync`),
//!   whose size its user picks (`new HDRCubeTexture(url, scene, size)`); hdrflow's default is 256,
//!   draft 128, high 512, with the sample counts of its other presets. Texels: RGBD 8-bit PNG (up
//!   to 255; brighter ones are clamped and counted in a warning).
//!
//! Checked in Babylon.js 9.37.1 itself (tests/babylon_render.rs): spheres of roughness 0 to 1 and
//! a diffuse one against Babylon's shader formula fed exact values, each classic mistake failing.

use super::{Chain, Engine, Preset, Quality, SpecSize};
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

/// Babylon's `lodGenerationScale` (`formats::babylon_env::LOD_GENERATION_SCALE`).
const LOD_SCALE: f64 = crate::formats::babylon_env::LOD_GENERATION_SCALE;

/// The roughness of each level of a chain of faces of `size` and `levels` levels (see the
/// module doc): `sqrt(2^(l / 0.8) / size)`, 0 at level 0, at most 1.
pub fn level_roughness(size: usize, levels: usize) -> Vec<f64> {
    (0..levels)
        .map(|l| if l == 0 { 0.0 } else { (2f64.powf(l as f64 / LOD_SCALE) / size as f64).sqrt().min(1.0) })
        .collect()
}

/// The lines that add the extracted sun as a `DirectionalLight` (also the glTF preset's, whose
/// light Babylon loads: `gltf.rs`).
pub const SUN_CODE: &str = r#"// The sun taken out of the map ({file:save_sun}): intensity = its irradiance in the map's units (Babylon's
// PBR divides a light's diffuse term by pi), direction in Babylon's left-handed world (z negated).
import { Color3, DirectionalLight, Vector3 } from '@babylonjs/core';
const sun = new DirectionalLight('sun', new Vector3({sun:from_light}).multiplyByFloats(1, 1, -1), scene);
sun.diffuse = new Color3({sun:color});
sun.intensity = {sun:illuminance};
"#;

pub const PRESET: Preset = Preset {
    engine: Engine::Babylon,
    name: "babylon",
    loads: "scene.environmentTexture: a .env (CubeTexture.CreateFromPrefilteredData): RGBD PNG faces of every level and the irradiance polynomial",
    world: "left-handed, +Y up, +Z forward: hdrflow's (X, Y, -Z)",
    cube_frame: Some(CubeFrame::MirrorZ),
    roughness_map: Some(RoughnessMap::List),
    level_roughness: Some(level_roughness),
    lod: "lod = 0.8 log2(size (r^2 + 0.0005))",
    irradiance: "Babylon's spherical polynomial (SphericalPolynomial.FromHarmonics of the SH of E / pi), in Babylon's world",
    files: "{name}.env, {name}_sun.json",
    texel_formats: "RGBD 8-bit PNG (values up to 255) inside the .env",
    centre_yaw: 0.0,
    tools: &[],
    quality: Some([
        // Babylon's own HDRFiltering takes 4096 samples a texel; at 1024 a sun kept in the map
        // (--sun keep) left the roughness-0.25 sphere 0.089 off Babylon's formula, 0.039 at 4096
        // (docs/src/guides/baking/babylon.md, "Against Babylon's own prefiltering").
        Quality { spec_size: SpecSize::Fixed(128), samples: 1024, irradiance_size: None },
        Quality { spec_size: SpecSize::Fixed(256), samples: 4096, irradiance_size: None },
        Quality { spec_size: SpecSize::Fixed(512), samples: 8192, irradiance_size: None },
    ]),
    chain: Chain::ToOneTexel,
    size_rule: Some("Babylon's .env loader needs a power-of-two cube size (\"Texture size must be a power of two\")"),
    check_assets: None,
    pipeline: include_str!("../../graphs/bake/babylon.ron"),
    loading_code: r#"// Babylon.js (@babylonjs/core 9), in a module with your `scene`; left-handed as by default, the map's
// centre faces +Z, the default camera's forward.
import { CubeTexture } from '@babylonjs/core';
const envUrl = '{file:save_env}';
scene.environmentTexture = CubeTexture.CreateFromPrefilteredData(envUrl, scene);
// The map as the background too (the .env's level 0):
scene.createDefaultSkybox(scene.environmentTexture, true, 1000, 0);
"#,
    sun_code: SUN_CODE,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Babylon's HDRFiltering: level l of a 256 cube holds alphaG = 2^(l / 0.8) / 256, which the
    /// shader reads back at lod = 0.8 log2(256 alphaG) = l.
    #[test]
    fn level_roughness_is_what_babylons_shader_reads_at_each_level() {
        let r = level_roughness(256, 9);
        assert_eq!(r[0], 0.0);
        for (l, r) in r.iter().enumerate().skip(1).take(6) {
            let lod = LOD_SCALE * (256.0 * r * r).log2();
            assert!((lod - l as f64).abs() < 1e-9, "{l}: {lod}");
        }
        assert_eq!(&r[7..], &[1.0, 1.0]);
        assert_eq!(level_roughness(128, 8).len(), 8);
    }
}
