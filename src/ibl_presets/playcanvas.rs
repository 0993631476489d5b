//! PlayCanvas (`playcanvas/engine`, npm `playcanvas` 2.x): `app.scene.envAtlas`, the 512 x 512
//! RGBP atlas of equirect reflection levels and ambient its `EnvLighting.generateAtlas` renders
//! (the layout, the seams and the shader's reads: `formats::playcanvas_atlas`; RGBP:
//! `formats::rgbp`), and `app.scene.skybox`, a cube map its `EnvLighting.generateSkyboxCubemap`
//! makes from the map as an RGBP equirect texture:
//!
//! - World: right-handed, +Y up, the default camera looking down -Z: hdrflow's axes. Its equirect
//!   puts +Z at the centre (`toSphericalUv(d * (-1, 1, 1))`), so the atlas is written by world
//!   direction (`PlayCanvasEnvAtlas`) and the skybox turned by half a turn (`Rotate(yaw: 180)`):
//!   the map's centre faces -Z, as in hdrflow, unmirrored. PlayCanvas' own tools, fed the map as
//!   it is, put its centre at +Z (`tools`).
//! - Levels: the atlas' rough levels 1..6 hold GGX of perceptual roughness 2/11, 4/11, 6/11,
//!   8/11, 10/11 and 1 (its `specularPower` 512 ... 1, `1 - log2(power) / 11`), its shiny mips the
//!   map; the shader reads `level = 5 r` (`r = 1 - gloss`), levels mixed linearly. hdrflow's chain
//!   is those 7 levels from a cube of 256 (draft 128, high 512; PlayCanvas' own source cube is
//!   128), exact GGX as the other presets (`PrefilterSpecular`, `roughness_map: List`).
//! - Ambient: E / pi (`IrradianceCubemap(method: Exact)`), which PlayCanvas adds to the diffuse
//!   light as it is.
//! - Texels: RGBP 8-bit PNG (values up to 64; brighter ones, a sun, are clamped and counted in a
//!   warning: `--sun extract`, the default, takes the sun out into a directional light).
//!
//! Checked in PlayCanvas 2.23.3 itself (tests/playcanvas_render.rs): spheres of roughness 0 to 1
//! and a diffuse one against PlayCanvas' shader formula fed exact values, each classic mistake
//! failing, and the skybox's orientation.

use super::{Chain, Engine, Preset, Quality, SpecSize, ToolPlacement};
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

/// The roughness of each level of the chain (any size): PlayCanvas' atlas levels.
pub fn level_roughness(_size: usize, _levels: usize) -> Vec<f64> {
    crate::formats::playcanvas_atlas::chain_roughness()
}

pub const PRESET: Preset = Preset {
    engine: Engine::Playcanvas,
    name: "playcanvas",
    loads: "app.scene.envAtlas: a 512 x 512 RGBP PNG atlas of equirect reflection levels and ambient; app.scene.skybox: a cube map made from an RGBP equirect PNG",
    world: "right-handed, +Y up, -Z forward (hdrflow's axes)",
    cube_frame: Some(CubeFrame::Standard),
    roughness_map: Some(RoughnessMap::List),
    level_roughness: Some(level_roughness),
    lod: "level = 5 r over the atlas' rough levels of roughness 2k/11 (k = 1..5)",
    irradiance: "the atlas' ambient rect: E / pi as a 62 x 30 equirect",
    files: "{name}_envAtlas.png, {name}_skybox.png, {name}_sun.json",
    texel_formats: "RGBP 8-bit PNG (values up to 64)",
    centre_yaw: 0.0,
    tools: &[ToolPlacement {
        tool: "PlayCanvas' EnvLighting.generateAtlas / generateSkyboxCubemap of the map as an equirect texture",
        centre: "+Z",
        mirrored: false,
        yaw: 180.0,
    }],
    quality: Some([
        Quality { spec_size: SpecSize::Fixed(128), samples: 256, irradiance_size: Some(32) },
        Quality { spec_size: SpecSize::Fixed(256), samples: 1024, irradiance_size: Some(32) },
        Quality { spec_size: SpecSize::Fixed(512), samples: 4096, irradiance_size: Some(32) },
    ]),
    chain: Chain::Levels(7),
    size_rule: None,
    check_assets: None,
    pipeline: include_str!("../../graphs/bake/playcanvas.ron"),
    loading_code: r#"// PlayCanvas (playcanvas 2), in an async module with your `app` (pc.Application): the atlas as the scene's
// lighting, the map as its skybox; both PNGs hold RGBP. The map's centre faces -Z, the default camera's forward.
import * as pc from 'playcanvas';
const atlasUrl = '{file:save_atlas}';
const skyUrl = '{file:save_sky}';
const loadRgbp = (url) => new Promise((resolve, reject) => {
    const asset = new pc.Asset(url, 'texture', { url }, { type: 'rgbp', mipmaps: false });
    asset.once('load', (a) => resolve(a.resource));
    asset.once('error', reject);
    app.assets.add(asset);
    app.assets.load(asset);
});
app.scene.envAtlas = await loadRgbp(atlasUrl);
app.scene.skybox = pc.EnvLighting.generateSkyboxCubemap(await loadRgbp(skyUrl));
"#,
    sun_code: r#"// The sun taken out of the map ({file:save_sun}): PlayCanvas adds a light's colour x intensity x n.l to the
// diffuse light without a 1 / pi, so the light is its irradiance / pi; it shines along the entity's -Y. PlayCanvas
// takes a light's colour gamma-encoded (it raises it to 2.2, and the colour times the intensity when the intensity
// is below 1), so the irradiance / pi goes into the colour, encoded, with intensity 1.
const sun = new pc.Entity('sun');
sun.addComponent('light', { type: 'directional', color: new pc.Color({sun:color}).mulScalar({sun:illuminance} / Math.PI).gamma(), intensity: 1 });
sun.setRotation(new pc.Quat().setFromDirections(pc.Vec3.DOWN, new pc.Vec3({sun:from_light})));
app.root.addChild(sun);
"#,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_chain_is_the_atlas_levels() {
        let r = level_roughness(256, 7);
        assert_eq!(r.len(), 7);
        assert_eq!(r[0], 0.0);
        assert_eq!(r[6], 1.0);
        assert_eq!(PRESET.chain.levels(256), 7);
    }
}
