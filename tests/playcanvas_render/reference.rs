//! What each sphere pixel should be when PlayCanvas 2.23.3 renders it lit by a PlayCanvas bake's
//! `envAtlas` (the fragment shader the page records, `shaders.txt`; PlayCanvas'
//! `lit/frag/reflectionEnv.js`, `lit/frag/ambient.js`), in two forms:
//!
//! - `engine`: PlayCanvas' formula with every texture read replaced by its exact value. With
//!   `app.scene.skybox` set, as the README's lines set it, PlayCanvas compiles the atlas' "HQ"
//!   reflection (`lit/frag/reflectionEnvHQ.js`): the sharp reflection is the skybox cube, and
//!   `mix(sharp, mix(A, B, f), min(level, 1))` with A, B the atlas levels `floor(level)` and the
//!   next (level 0 being the map). Per pixel
//!   (normal n, surface point p, `v = normalize(camera - p)`: PlayCanvas takes the view vector from
//!   the camera's position also for an orthographic camera):
//!   1. the lookup direction `-reflect(v, n)` and the level `5 r` (`saturate(1 - gloss) * 5`,
//!      gloss = 1 - r); levels 1..5 hold the exact GGX prefiltered radiance (`ggx_reference::
//!      prefiltered`, n = v = r) at PlayCanvas' roughness `2k / 11` (`playcanvas_atlas::
//!      level_roughness`), mixed linearly by the level's fraction; level 0 and the skybox are the
//!      map itself (bilinear);
//!   2. the metal spheres have specular white and no Fresnel (`FRESNEL_NONE`), no diffuse: the
//!      pixel is the reflection of step 1; the diffuse sphere (diffuse white, specular black) the
//!      ambient rect's value: the exact `E(n) / pi`.
//! - `exact`: the single-scattering GGX integral at the nominal roughness with F = 1, the mirror's
//!   exact value the map in the mirror direction; the diffuse sphere's E / pi. PlayCanvas' split
//!   sum without a DFG factor is not this: reported, not asserted.
//!
//! Directions are hdrflow's, which are PlayCanvas' world directions.

use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::formats::playcanvas_atlas::{level_roughness, shader_level};
use hdrflow::maths::ibl::ggx_reference::{prefiltered, specular};
use hdrflow::maths::ibl::irradiance_cube::Texels;
use hdrflow::maths::render::reference::irradiance_exact;
use rayon::prelude::*;

use super::reference::{lookup, Map};
use super::scene::Sphere;

/// A sphere's two references (the formula fed exact values, the exact material).
pub type SphereReference = super::reference::EngineReference;

/// The exact content of rough level `k` (1..=6) of a correct atlas in each direction of `dirs`,
/// with `roughness(k)` the roughness each level holds.
fn level_values(map: &Map, k: usize, roughness: fn(usize) -> f64, dirs: &[DVec3]) -> Vec<[f64; 3]> {
    if k == 0 {
        return dirs.iter().map(|&d| lookup(&map.full, d)).collect();
    }
    let alpha = roughness(k).powi(2);
    let env = if alpha < 0.05 { &map.full } else { &map.for_ggx };
    let texels = Texels::from_latlong(env);
    dirs.par_chunks(64).flat_map_iter(|chunk| prefiltered(&texels, chunk, alpha)).collect()
}

/// The references of sphere `s` at `pixels` (index, unit normal) seen from an orthographic
/// camera at `camera`.
pub fn sphere_reference(map: &Map, s: &Sphere, pixels: &[(usize, DVec3)], camera: DVec3) -> SphereReference {
    assert!(s.metallic == 1.0 || s.metallic == 0.0, "{}: metallic 0 or 1 only", s.name);
    let normals: Vec<DVec3> = pixels.iter().map(|p| p.1).collect();
    let views: Vec<DVec3> = normals.iter().map(|&n| (camera - (s.centre + s.radius * n)).normalize()).collect();
    let mirror: Vec<DVec3> = normals.iter().zip(&views).map(|(&n, &v)| 2.0 * n.dot(v) * n - v).collect();
    let mut out =
        SphereReference { pixels: pixels.iter().map(|p| p.0).collect(), engine: Vec::new(), exact: Vec::new() };
    if s.metallic == 0.0 {
        let as_arrays: Vec<[f64; 3]> = normals.iter().map(|n| n.to_array()).collect();
        let diffuse: Vec<[f64; 3]> =
            irradiance_exact(&map.full, &as_arrays).iter().map(|e| e.map(|c| c / PI)).collect();
        out.engine = diffuse.clone();
        out.exact = diffuse;
        return out;
    }
    let level = shader_level(s.roughness);
    let base = (level.floor() as usize).min(5);
    let f = level - base as f64;
    let mut blended = level_values(map, base, level_roughness, &mirror);
    if f > 0.0 {
        for (b, next) in blended.iter_mut().zip(level_values(map, base + 1, level_roughness, &mirror)) {
            for c in 0..3 {
                b[c] = (1.0 - f) * b[c] + f * next[c];
            }
        }
    }
    if base == 0 {
        // HQ: mix(sharp, mix(level 0, level 1, f), min(level, 1)), the sharp read and level 0 both the map.
        let sharp: Vec<[f64; 3]> = mirror.iter().map(|&d| lookup(&map.full, d)).collect();
        for (b, s) in blended.iter_mut().zip(&sharp) {
            for c in 0..3 {
                b[c] = (1.0 - level) * s[c] + level * b[c];
            }
        }
    }
    out.engine = blended;
    out.exact = if s.roughness == 0.0 {
        mirror.iter().map(|&d| lookup(&map.full, d)).collect()
    } else {
        let texels = Texels::from_latlong(&map.for_ggx);
        specular(&texels, &normals, &views, s.roughness.powi(2), [1.0; 3])
    };
    out
}

#[test]
fn the_shader_reads_level_5r_between_the_atlas_levels() {
    // roughness 0.25: level 1.25, between PlayCanvas' 2/11 and 4/11; roughness 1: level 5 (10/11).
    assert_eq!(shader_level(0.25), 1.25);
    assert_eq!(shader_level(1.0), 5.0);
    assert!((level_roughness(5) - 10.0 / 11.0).abs() < 1e-12);
}
