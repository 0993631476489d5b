//! The Khronos glTF Sample Viewer and Vulkan samples, with the files glTF-IBL-Sampler
//! (`KhronosGroup/glTF-IBL-Sampler`, lib/source/shaders/filter.frag, lib/source/lib.cpp) writes:
//!
//! - Cube size: the panorama's height / 2 (`panoramaExtent.height / 2`), mip levels down to the
//!   smallest, 1024 samples, RGBA16F KTX2; the level for a roughness `r` is `r (N - 1)` in the
//!   viewer (`getIBLRadianceGGX`), so level k is filtered for `k / (N - 1)`: `RoughnessMap::Linear`.
//! - Three chains: GGX (`ggx/specular.ktx2`), Charlie for sheen (`charlie/sheen.ktx2`,
//!   `PrefilterSpecular(brdf: Charlie)`), Lambertian (`lambertian/diffuse.ktx2`, `E / pi`), and
//!   two LUTs, x = n.v, y = roughness, row 0 = roughness 0, the size of the cube: GGX
//!   (`lut_ggx.png`: R scale, G bias) and Charlie for sheen (`lut_charlie.png`, `BrdfLut(brdf:
//!   Charlie)`: B, read by the viewer's `getIBLRadianceCharlie` as `.b`; `maths::brdf::charlie`). The
//!   viewer's other sheen texture, `lut_sheen_E.png` (the albedo scaling of the layers below the
//!   sheen), depends on no environment and is not written: the viewer's own copy serves.
//! - Lookup: `textureLod(u_GGXEnvSampler, u_envRotation * reflection, lod)`, the world direction
//!   turned about +Y by the viewer's `environmentRotation` (90 degrees by default):
//!   `CubeFrame::Standard` for a rotation of 0. The sampler's `panoramaToCubeMap` (`uvToXYZ`,
//!   `dirToUV`: `u = 0.5 + atan2(z, x) / (2 pi)`) puts the panorama's centre on +X unmirrored:
//!   hdrflow's with a yaw of -90 degrees. The viewer's default rotation turns every map, the
//!   sampler's and hdrflow's alike, by the same 90 degrees (hdrflow's centre then faces +X, the
//!   sampler's +Z), so the yaw that reproduces the sampler is -90 at any rotation.
//! - The sun's light (`KHR_lights_punctual`, `schema/light.schema.json`): `color` is linear RGB with
//!   each channel in [0, 1] and `intensity` (lux for a directional light) multiplies it, so the
//!   notes write the sun's irradiance divided by its largest channel, and that channel.

use super::{Chain, Engine, Preset, Quality, SpecSize, ToolPlacement};
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

pub const PRESET: Preset = Preset {
    engine: Engine::Khronos,
    name: "khronos",
    loads: "ggx/specular.ktx2, charlie/sheen.ktx2, lambertian/diffuse.ktx2 (KTX2 cube maps with mips), the GGX and the Charlie LUTs",
    world: "right-handed, +Y up (glTF); environmentRotation 0: hdrflow's axes",
    cube_frame: Some(CubeFrame::Standard),
    roughness_map: Some(RoughnessMap::Linear),
    level_roughness: None,
    lod: "lod = r (N - 1)",
    irradiance: "a cube map of E / pi, times the diffuse colour",
    files: "ggx/specular.ktx2, charlie/sheen.ktx2, lambertian/diffuse.ktx2, lut_ggx.png, lut_charlie.png, {name}_sun.json",
    texel_formats: "RGBA16F KTX2 (as glTF-IBL-Sampler), the LUTs as 16-bit linear PNGs (as the glTF Sample Viewer reads them; \
                    the Charlie LUT's values above 1 clamped, as the sampler's 8-bit PNG)",
    centre_yaw: 0.0,
    tools: &[ToolPlacement {
        tool: "glTF-IBL-Sampler (at the viewer's default environmentRotation 90: +Z)",
        centre: "+X",
        mirrored: false,
        yaw: -90.0,
    }],
    quality: Some([
        Quality { spec_size: SpecSize::MapHeightOver(4), samples: 256, irradiance_size: Some(16) },
        Quality { spec_size: SpecSize::MapHeightOver(2), samples: 1024, irradiance_size: Some(32) },
        Quality { spec_size: SpecSize::MapHeightOver(2), samples: 4096, irradiance_size: Some(64) },
    ]),
    chain: Chain::ToOneTexel,
    size_rule: None,
    check_assets: None,
    pipeline: include_str!("../../graphs/bake/khronos.ron"),
    loading_code: r#"// glTF Sample Viewer / a Vulkan renderer: upload the three KTX2 cube maps with all their levels
// and sample them with the world direction (environmentRotation 0 to see the map's centre at -Z).
//   {file:save_spec}   GGX, lod = roughness * (levels - 1)
//   {file:save_sheen}  Charlie (sheen), lod = sheenRoughness * (levels - 1)
//   {file:save_irr}    Lambertian: diffuse = baseColor * texture(lambertian, n)
//   {file:save_lut}    GGX LUT: specular = prefiltered * (F0 * lut.r + lut.g)
//   {file:save_lut_charlie}  Charlie LUT: sheen = prefiltered sheen * sheenColor * lut.b (u_CharlieLUT)
vec3 specular = textureLod(u_GGXEnvSampler, reflect(-v, n), roughness * float(u_MipCount - 1)).rgb;

// The glTF Sample Renderer (npm @khronosgroup/gltf-viewer 1.1.0) filters panoramas itself; to light
// a scene with these files instead, give it the environment its loadEnvironment would build, as
// hdrflow's test page does (clients/khronos-web/render.js, loadBake): each KTX2 file through
// view.ktxDecoder.loadKtxFromBuffer, trilinear and clamped, the LUTs as PNG images, then
//   state.environment = { samplers, images, textures, diffuseEnvMap, specularEnvMap, sheenEnvMap,
//                         lut, sheenLUT, mipCount: <the chain's levels>, iblIntensityScale: 1 };
//   state.renderingParameters.environmentRotation = 0;  // its default of 90 turns the map
"#,
    sun_code: r#"// The sun taken out of the map ({file:save_sun}) as a KHR_lights_punctual directional light (its schema
// keeps each channel of "color" in [0, 1]; the renderer multiplies it by "intensity": color x intensity is the
// irradiance the sun gives, in the map's units, of Rec. 709 luminance {sun:illuminance}):
// "lights": [{ "type": "directional", "color": [{sun:unit_color}], "intensity": {sun:peak} }]
// on a node whose -Z axis points along ({sun:from_light}).
"#,
};
