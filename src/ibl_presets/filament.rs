//! Filament (`google/filament`, `IndirectLight`), as `cmgen` (tools/cmgen/src/cmgen.cpp,
//! libs/ibl) writes it for `--deploy`:
//!
//! - Levels: `numLevels = log2(size) + 1 - log2(16)` (256 down to 16: 5), level l filtered for
//!   `r = lodToPerceptualRoughness(l / (N - 1))`, the inverse of the shader's
//!   `lod = iblRoughnessOneLevel r (2 - r)` (shaders/src/surface_light_indirect.fs):
//!   `RoughnessMap::Filament`. 1024 samples (cmgen doubles them from level 2 on, for plain
//!   importance sampling; hdrflow's filtered importance sampling keeps 1024: docs/src/benchmarks/ibl.md,
//!   image-based lighting, sections 4-5).
//! - The cube is sampled with the world direction (`textureLod(sampler0_iblSpecular, r, lod)`),
//!   OpenGL faces: `CubeFrame::Standard`. cmgen's lat-long mapping puts the map's centre at +Z
//!   (`atan2(x, z)`), mirrored, then mirrors the cube by default (`mirrorCubemap`: x negated),
//!   so cmgen's result faces +Z unmirrored: hdrflow's with a yaw of 180 degrees.
//! - Irradiance: 9 SH pre-scaled for the shader (`--sh-shader`; `E / pi = sh0 + sh1 y + ...`),
//!   written to `sh.txt` and the KTX key `sh` (`maths::ibl::sh_filament`). cmgen windows them by
//!   default (`--sh-window=auto`); hdrflow does not.
//! - Files: `<name>_ibl.ktx` (the chain), `<name>_skybox.ktx` (level 0), `sh.txt`; KTX1,
//!   R11F_G11F_B10F. Size: a power of two ("output size must be a power of two").
//! - The sun (`--sun extract`): a `SUN` light of `I E` lux, `I` the IBL's intensity (30000 in the
//!   loading code) and `E` the sun's illuminance in the map's units (`{sun:illuminance}`). The
//!   IBL's intensity multiplies the map's radiance (IndirectLight.h: "scale factor applied to the
//!   environment and irradiance such that the result is in lux"), and a directional light's
//!   intensity is the illuminance it gives a surface facing it (LightManager.h, lux), which the
//!   map's sun gave as `E` times the same scale: a user who changes the IBL's intensity scales
//!   the sun with it. The lines create the light's entity and add it to the scene, as a user's
//!   code must.
//!
//! Checked in Filament itself (1.53.4's web build, tests/filament_render.rs): the frame, the
//! roughness map and the SH scale as stated here, with the map's centre forward and unmirrored;
//! the sun's lines, translated token by token into filament.js and run, light the diffuse sphere
//! as the `--sun keep` bake does (within 0.08 relative RMSE of it, and 0.025 of exact E / pi).

use super::{Chain, Engine, Preset, Quality, SpecSize, ToolPlacement};
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

pub const PRESET: Preset = Preset {
    engine: Engine::Filament,
    name: "filament",
    loads:
        "IndirectLight: a reflections cube map with its mips (KTX1 from cmgen) and 9 pre-scaled irradiance SH; a Skybox",
    world: "right-handed, +Y up, -Z forward (hdrflow's axes)",
    cube_frame: Some(CubeFrame::Standard),
    roughness_map: Some(RoughnessMap::Filament),
    level_roughness: None,
    lod: "lod = (N - 1) r (2 - r)",
    irradiance:
        "9 SH pre-scaled by the cosine lobe and the basis constants: E / pi = sh0 + sh1 y + sh2 z + sh3 x + ...",
    files: "{name}_ibl.ktx, {name}_skybox.ktx, sh.txt, {name}_sun.json",
    texel_formats: "KTX1 R11F_G11F_B10F, the SH also under the key sh, as cmgen writes them",
    centre_yaw: 0.0,
    tools: &[
        ToolPlacement { tool: "cmgen (default: it mirrors)", centre: "+Z", mirrored: false, yaw: 180.0 },
        ToolPlacement { tool: "cmgen --no-mirror", centre: "+Z", mirrored: true, yaw: 180.0 },
    ],
    quality: Some([
        Quality { spec_size: SpecSize::Fixed(128), samples: 256, irradiance_size: None },
        Quality { spec_size: SpecSize::Fixed(256), samples: 1024, irradiance_size: None },
        Quality { spec_size: SpecSize::Fixed(512), samples: 4096, irradiance_size: None },
    ]),
    chain: Chain::ToSize(16),
    size_rule: Some(
        "cmgen and Filament's IBL need a power-of-two cube size (cmgen: \"output size must be a power of two\")",
    ),
    check_assets: None,
    pipeline: include_str!("../../graphs/bake/filament.ron"),
    loading_code: r#"// Filament (C++), with libs/ktxreader as its samples use it; the SH is also sh.txt's 9 lines.
image::Ktx1Bundle* iblBundle = new image::Ktx1Bundle(iblBytes, iblSize);      // {file:save_spec}
filament::math::float3 sh[9];
iblBundle->getSphericalHarmonics(sh);
Texture* reflections = ktxreader::Ktx1Reader::createTexture(engine, iblBundle, false);
image::Ktx1Bundle* skyBundle = new image::Ktx1Bundle(skyBytes, skySize);      // {file:save_sky}
Texture* skyTexture = ktxreader::Ktx1Reader::createTexture(engine, skyBundle, false);
IndirectLight* ibl = IndirectLight::Builder()
        .reflections(reflections)
        .irradiance(3, sh)
        .intensity(30000.0f)   // lux per unit of the map
        .build(*engine);
scene->setIndirectLight(ibl);
scene->setSkybox(Skybox::Builder().environment(skyTexture).build(*engine));
"#,
    sun_code: r#"// The sun taken out of the map ({file:save_sun}): its illuminance in the map's units times the
// IBL's intensity above (30000 lux per unit of the map), so the sun is the light the map held.
utils::Entity sunEntity = utils::EntityManager::get().create();
LightManager::Builder(LightManager::Type::SUN)
        .color({ {sun:color} })
        .intensity(30000.0f * {sun:illuminance})
        .direction({ {sun:from_light} })
        .sunAngularRadius({sun:radius_deg})
        .build(*engine, sunEntity);
scene->addEntity(sunEntity);
"#,
};
