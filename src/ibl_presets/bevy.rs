//! Bevy (`bevyengine/bevy`, `EnvironmentMapLight`), read from its sources (0.16-0.19):
//!
//! - `crates/bevy_pbr/src/light_probe/environment_map.wgsl`: the specular level is
//!   `perceptual_roughness * smallest_specular_mip_level` (= r (N - 1), `textureNumLevels - 1`),
//!   and both cube maps are sampled with `sample_dir.z = -sample_dir.z` ("cube maps are
//!   left-handed"): a cube written in hdrflow's frame must be z-mirrored (`CubeFrame::MirrorZ`).
//! - The diffuse map is multiplied by the diffuse colour (`diffuse_color * irradiance`): it holds
//!   `E / pi`, `IrradianceCubemap`'s convention; `intensity` scales both maps to cd/m^2.
//! - A pixel is `exposure * intensity * map` (`pbr_functions.wgsl`: `view.exposure * (... +
//!   indirect_light)`), with the camera's `exposure = 2^-ev100 / 1.2` (`bevy_camera`'s
//!   `Exposure::exposure`); a camera without `Exposure` has `Exposure::default()`, EV100 9.7
//!   (`Exposure::BLENDER`): `1 / 998.0957`. So `intensity: 998.0957` (= `1.2 * 2^9.7`) renders the
//!   map's values 1:1 under the default exposure, as the render test does with intensity 1 and
//!   `ev100 = -log2(1.2)` (clients/bevy: `exposure * intensity = 1`). `EnvironmentMapLight`'s own
//!   default intensity is 0.
//! - Bevy's world: right-handed, +Y up, cameras look down -Z: hdrflow's.
//! - Its sample assets (`assets/environment_maps/*_{diffuse,specular}_rgb9e5_zstd.ktx2`) were made
//!   with glTF-IBL-Sampler and `bevy_mod_environment_map_tools`; its runtime
//!   `GeneratedEnvironmentMapLight` filters a 32-texel diffuse map. Defaults: a 256 specular chain
//!   down to 1 x 1 (9 levels), 1024 samples (glTF-IBL-Sampler's), a 32 diffuse map.
//! - The sun (`--sun extract`): a `DirectionalLight` of `I E` lux, `I` the `EnvironmentMapLight`'s
//!   intensity (998.0957 in the loading code) and `E` the sun's illuminance in the map's units
//!   (`{sun:illuminance}`). Bevy premultiplies the light's colour by its illuminance
//!   (`bevy_pbr/src/render/light.rs`) and shades
//!   `exposure * (diffuse_color * Fd_Burley + specular) * NdotL` times it (`pbr_lighting.wgsl`,
//!   `directional_light`), while the maps give `exposure * intensity * map`: the sun is the light
//!   the map held when its illuminance is `E` times the same `intensity`, and a user who changes
//!   the intensity (or the camera's `Exposure`) scales both.
//!   The field is `shadow_maps_enabled` since Bevy 0.19 (`shadows_enabled` before: contact
//!   shadows, Bevy PR 22382); the lines say so.
//!
//! Checked in Bevy itself (0.19.1 on lavapipe, tests/bevy_render.rs): the frame, the roughness
//! map and the exposure as stated here, the map's centre forward and unmirrored; the sun's lines,
//! read by the client's strict reader of their Rust (clients/bevy/src/sun_lines.rs) and spawned
//! under the loading code's intensity and default exposure, light the diffuse sphere as the `--sun
//! keep` bake does (within 0.09 relative RMSE of it and of exact E / pi: Bevy shades direct light
//! with Burley's diffuse, not Lambert's).

use super::{Chain, Engine, Preset, Quality, SpecSize, ToolPlacement};
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

pub const PRESET: Preset = Preset {
    engine: Engine::Bevy,
    name: "bevy",
    loads: "EnvironmentMapLight { diffuse_map, specular_map, intensity }: two KTX2 cube maps, the specular one with its full mip chain",
    world: "right-handed, +Y up, -Z forward (hdrflow's axes)",
    cube_frame: Some(CubeFrame::MirrorZ),
    roughness_map: Some(RoughnessMap::Linear),
    level_roughness: None,
    lod: "lod = r (N - 1)",
    irradiance: "a cube map of E / pi, times the diffuse colour",
    files: "{name}_specular_rgb9e5_zstd.ktx2, {name}_diffuse_rgb9e5_zstd.ktx2, {name}_sun.json",
    texel_formats: "KTX2 E5B9G9R9_UFLOAT_PACK32 (rgb9e5) with Zstandard, as Bevy's own assets",
    centre_yaw: 0.0,
    tools: &[ToolPlacement {
        tool: "glTF-IBL-Sampler + bevy_mod_environment_map_tools (Bevy's sample assets)",
        centre: "+X",
        mirrored: true,
        yaw: -90.0,
    }],
    quality: Some([
        Quality { spec_size: SpecSize::Fixed(128), samples: 256, irradiance_size: Some(16) },
        Quality { spec_size: SpecSize::Fixed(256), samples: 1024, irradiance_size: Some(32) },
        Quality { spec_size: SpecSize::Fixed(512), samples: 4096, irradiance_size: Some(64) },
    ]),
    chain: Chain::ToOneTexel,
    size_rule: None,
    check_assets: None,
    pipeline: include_str!("../../graphs/bake/bevy.ron"),
    loading_code: r#"// Bevy (0.16-0.19), with its `ktx2` and `zstd_rust` (or `zstd_c`) features; copy these files into assets/environment_maps/.
commands.spawn((
    Camera3d::default(),
    EnvironmentMapLight {
        diffuse_map: asset_server.load("environment_maps/{file:save_irr}"),
        specular_map: asset_server.load("environment_maps/{file:save_spec}"),
        // Bevy shows exposure x intensity x the maps' values; the camera's default Exposure
        // (EV100 9.7) is 2^-9.7 / 1.2 = 1 / 998.0957, so this renders the map 1:1 (a texel of 1
        // shows as 1). For a map in cd/m^2, use 1.0 and give the camera the Exposure you want.
        intensity: 998.0957,
        ..default()
    },
));
"#,
    sun_code: r#"// The sun taken out of the map ({file:save_sun}); multiply by the same intensity as above.
// Bevy 0.16-0.18: `shadows_enabled` (renamed `shadow_maps_enabled` in 0.19).
commands.spawn((
    DirectionalLight { illuminance: {sun:illuminance} * 998.0957, color: Color::linear_rgb({sun:color}), shadow_maps_enabled: true, ..default() },
    // a directional light shines along its forward (-Z): towards -(direction to the sun)
    Transform::default().looking_to(Vec3::new({sun:from_light}), Vec3::Y),
));
"#,
};
