//! three.js (`mrdoob/three.js`):
//!
//! - `scene.environment` / `scene.background` take an equirectangular texture
//!   (`EquirectangularReflectionMapping`) that three prefilters itself (PMREMGenerator, its
//!   CubeUV atlas); a float cube map cannot come from its KTX2 loader (#27501), so the map is
//!   written as a Radiance `.hdr` for `HDRLoader` / `RGBELoader`.
//! - Its lat-long lookup (`equirectUv`: `u = atan2(z, x) / (2 pi) + 0.5`) puts a map's centre on
//!   +X unmirrored: hdrflow's with a yaw of -90 degrees. The preset writes the map turned by +90
//!   degrees (`centre_yaw`, an exact roll of a quarter of the columns), so that its centre faces
//!   -Z in three's world as it does in hdrflow's, and world directions agree.
//! - `LightProbe` takes `SphericalHarmonics3`: 9 orthonormal radiance coefficients, world axes,
//!   `0.488603 y, 0.488603 z, 0.488603 x, ...` in slots 1-3: `ShIrradiance(frame: World)`.
//! - Any size (no power-of-two rule); the map keeps its size.
//!
//! `tests/three_render.rs` checks these conventions in three.js 0.187 itself (docs/src/guides/baking/three.md, "three.js,
//! rendered"): the turned map as `scene.background` shows its centre along -Z, not mirrored; the
//! SH file in a `LightProbe` lights a white sphere as the map's exact irradiance does, to the
//! order-2 SH's own error. Its page (clients/three-web/render.js) loads the files with the lines
//! of `loading_code`: `tests/bake.rs` checks that each of them but the two naming the files is a
//! line of that page.

use super::{Chain, Engine, Preset, ToolPlacement};

pub const PRESET: Preset = Preset {
    engine: Engine::Three,
    name: "three",
    loads: "scene.environment: an equirectangular HDR texture (prefiltered by PMREMGenerator); LightProbe: SphericalHarmonics3",
    world: "right-handed, +Y up, -Z forward (hdrflow's axes)",
    cube_frame: None,
    roughness_map: None,
    level_roughness: None,
    lod: "its own PMREM (CubeUV atlas)",
    irradiance: "PMREM of the map, or a LightProbe of 9 orthonormal SH (SphericalHarmonics3)",
    files: "{name}_three.hdr, {name}_sh.json, {name}_sun.json",
    texel_formats: "Radiance RGBE (.hdr)",
    centre_yaw: 90.0,
    tools: &[ToolPlacement {
        tool: "three.js with the map as it is (EquirectangularReflectionMapping)",
        centre: "+X",
        mirrored: false,
        yaw: -90.0,
    }],
    quality: None,
    chain: Chain::None,
    size_rule: None,
    check_assets: None,
    pipeline: include_str!("../../graphs/bake/three.ron"),
    loading_code: r#"// three.js r180 or later (HDRLoader; before r180 the same calls on RGBELoader, RGBELoader.js), in a
// module with your `scene`; the map is written turned so that its centre faces -Z, as in hdrflow. Full
// floats: with three's default, half floats, radiance above 65504 (a sun) is clipped to 65504.
import * as THREE from 'three';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
const mapUrl = '{file:save_map}';
const texture = await new HDRLoader().setDataType(THREE.FloatType).loadAsync(mapUrl);
texture.mapping = THREE.EquirectangularReflectionMapping;
scene.environment = texture;
scene.background = texture;
// Or diffuse light alone, from the 9 SH of {file:save_sh}:
const shUrl = '{file:save_sh}';
const json = await (await fetch(shUrl)).json();
scene.add(new THREE.LightProbe(new THREE.SphericalHarmonics3().fromArray(json.coefficients.flat())));
"#,
    sun_code: r#"// The sun taken out of the map ({file:save_sun}); intensity in the map's units (irradiance).
const sun = new THREE.DirectionalLight(new THREE.Color().setRGB({sun:color}, THREE.LinearSRGBColorSpace), {sun:illuminance});
sun.position.set({sun:to_light}).multiplyScalar(100);
scene.add(sun);
"#,
};

#[cfg(test)]
mod tests {
    use super::PRESET;
    use crate::geometry::latlong;
    use crate::geometry::rotation::Rotation;
    use crate::maths::resample::rotation::rotate_latlong;
    use crate::values::Image;

    /// three.js reads world direction d at `u = atan2(d.z, d.x) / (2 pi) + 0.5`, `v = asin(d.y) /
    /// pi + 0.5` from the bottom (`equirectUv`): after the preset's turn, a texel of hdrflow's
    /// map lands at the (u, v) three reads its direction at, forward (-Z) included.
    #[test]
    fn the_turned_map_puts_each_direction_where_three_reads_it() {
        let (w, h) = (64, 32);
        for (x, y) in [(32, 16), (10, 5), (50, 20), (0, 31)] {
            let mut img = Image::new(w, h, 3);
            img.pixel_mut(x, y)[0] = 1.0;
            let turned = rotate_latlong(&img, Rotation::from_yaw_pitch_roll(PRESET.centre_yaw, 0.0, 0.0));
            let lit = turned.data.chunks(3).position(|p| p[0] == 1.0).expect("a whole-column roll keeps the texel");
            let (tx, ty) = (lit % w, lit / w);
            let [dx, dy, dz] = latlong::texel_direction(x, y, w, h);
            let u = dz.atan2(dx) / (2.0 * std::f64::consts::PI) + 0.5;
            let v_top = 1.0 - (dy.clamp(-1.0, 1.0).asin() / std::f64::consts::PI + 0.5);
            let want = ((u * w as f64).floor() as usize % w, (v_top * h as f64).floor() as usize);
            assert_eq!((tx, ty), want, "texel ({x}, {y})");
        }
    }
}
