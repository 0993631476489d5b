//! What each sphere pixel should be when Babylon.js 9.37.1 renders it lit by a Babylon bake, a
//! `.env` or a glTF asset's `EXT_lights_image_based` light (tests/gltf_render.rs) (the
//! fragment shader the page records, `shaders.txt`; Babylon's `pbrBlockReflection.fx`,
//! `pbrIBLFunctions.fx`, `pbrBlockFinalLitComponents.fx`), in two forms:
//!
//! - `engine`: Babylon's formula with every texture lookup replaced by its exact value. Per pixel
//!   (normal n, surface point p, `v = normalize(camera - p)`: Babylon takes the view vector from
//!   the camera's position also for an orthographic camera):
//!   1. the lookup direction `reflect(-v, n)` and the level `lod = s log2(W alphaG)`, `alphaG =
//!      r^2 + 0.0005` (`convertRoughnessToAverageSlope`, `getLodFromAlphaG`, `lodGenerationScale`
//!      s: 0.8 for a `.env`, `(N - 1) / log2(W)` for a glTF light of N levels: [`Levels`]), clamped
//!      to the chain, read trilinearly: `(1 - f) P_k + f P_k+1`, where `P_0` is the
//!      map itself (bilinear) and `P_k` the exact GGX prefiltered radiance (`ggx_reference::
//!      prefiltered`) at the `alphaG_k = 2^(k / s) / W` the shader reads at level k (for a `.env`
//!      Babylon's own `HDRFiltering`: what a correct chain holds; hdrflow caps the roughness at 1,
//!      which levels 7 and 8 of a 256 cube exceed). Faces of at most 32 texels: the exact values at the level's texel centres,
//!      interpolated bilinearly across face edges, as the GPU reads a perfect level;
//!   2. `MIX_IBL_RADIANCE_WITH_IRRADIANCE` (Babylon's default): the radiance becomes
//!      `mix(P, I(n), alphaG)`, I the irradiance term at the normal;
//!   3. white metal (F0 = F90 = 1): the split-sum reflectance times Babylon's energy conservation
//!      factor `1 + F0 (1 / brdf.y - 1)` is exactly 1, so the pixel is the radiance of step 2;
//!      the diffuse sphere (no specular: `metallicF0Factor` 0, Lambert): I(n), albedo 1.
//!
//!   I(n) is the order-2 SH irradiance over pi of the map (what a correct polynomial gives):
//!   Babylon's evaluation (`formats::babylon_env::Polynomial::irradiance`) of the polynomial of
//!   the map's 9 exact SH (`maths::ibl::sh`), at n.
//! - `exact`: the material without the split sum and the order-2 SH: the single-scattering GGX
//!   integral at the nominal roughness plus the energy single scattering loses, `(1 - E_ss) E / pi`,
//!   the mirror's exact value the map in the mirror direction; the diffuse sphere's E / pi.
//!   Reported, not asserted.
//!
//! Directions are hdrflow's (the page turns them into Babylon's left-handed world).

use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::formats::babylon_env::Polynomial;
use hdrflow::geometry::cubemap as cube;
use hdrflow::maths::brdf::ggx::{dfg, points, LobeSequence};
use hdrflow::maths::ibl::ggx_reference::{prefiltered, specular};
use hdrflow::maths::ibl::irradiance_cube::Texels;
use hdrflow::maths::ibl::sh::project_turned;
use hdrflow::maths::render::reference::irradiance_exact;
use hdrflow::values::ShFrame;
use rayon::prelude::*;

use super::reference::{cube_bilinear, lookup, Map};
use super::scene::Sphere;

/// The shader's smallest `alphaG` addend (`MINIMUMVARIANCE`).
const MINIMUM_VARIANCE: f64 = 0.0005;

/// The chain Babylon samples: level 0's face size, the number of levels, `lodGenerationScale`.
#[derive(Clone, Copy, Debug)]
pub struct Levels {
    pub size: usize,
    pub count: usize,
    pub lod_scale: f64,
}

impl Levels {
    /// A `.env`'s: every level down to 1 x 1, `lodGenerationScale` 0.8.
    pub fn env(size: usize) -> Levels {
        Levels { size, count: size.trailing_zeros() as usize + 1, lod_scale: 0.8 }
    }

    /// A glTF light's of `count` levels: the loader's `lodGenerationScale`, `(N - 1) / log2(size)`.
    pub fn gltf(size: usize, count: usize) -> Levels {
        Levels { size, count, lod_scale: (count - 1) as f64 / (size as f64).log2() }
    }
}

/// A sphere's two references (the formula fed exact values, the exact material).
pub type SphereReference = super::reference::EngineReference;

/// Faces this small or smaller are modelled texel by texel (module doc, step 1).
const COARSE: usize = 32;

/// The exact content of level `k` of the chain `levels` in each direction of `dirs`.
fn level_values(map: &Map, k: usize, levels: Levels, dirs: &[DVec3]) -> Vec<[f64; 3]> {
    if dirs.is_empty() {
        return Vec::new();
    }
    if k == 0 {
        return dirs.iter().map(|&d| lookup(&map.full, d)).collect();
    }
    let size = levels.size;
    let alpha = 2f64.powf(k as f64 / levels.lod_scale) / size as f64;
    let env = if alpha < 0.05 { &map.full } else { &map.for_ggx };
    let texels = Texels::from_latlong(env);
    let face = (size >> k).max(1);
    if face <= COARSE {
        let centres: Vec<DVec3> = (0..6)
            .flat_map(|f| (0..face).flat_map(move |y| (0..face).map(move |x| cube::texel_direction(f, x, y, face))))
            .collect();
        let values: Vec<[f64; 3]> = centres.par_chunks(64).flat_map_iter(|c| prefiltered(&texels, c, alpha)).collect();
        return dirs.iter().map(|&d| cube_bilinear(&values, face, d)).collect();
    }
    dirs.par_chunks(64).flat_map_iter(|chunk| prefiltered(&texels, chunk, alpha)).collect()
}

/// The level Babylon's shader reads for perceptual roughness `r` on the chain `levels`.
pub fn shader_lod(r: f64, levels: Levels) -> f64 {
    (levels.lod_scale * (levels.size as f64 * (r * r + MINIMUM_VARIANCE)).log2()).clamp(0.0, (levels.count - 1) as f64)
}

/// The order-2 SH irradiance over pi of `map` as Babylon's polynomial, in hdrflow's axes.
pub fn sh_polynomial(map: &Map) -> Polynomial {
    Polynomial::from_sh(&project_turned(&map.full, 2, ShFrame::World, 0.0)).expect("9 coefficients")
}

/// The references of sphere `s` at `pixels` (index, unit normal) seen from an orthographic
/// camera at `camera`, lit by the chain `chain`.
pub fn sphere_reference(
    map: &Map,
    poly: &Polynomial,
    s: &Sphere,
    pixels: &[(usize, DVec3)],
    camera: DVec3,
    chain: Levels,
) -> SphereReference {
    let levels = chain.count;
    assert!(s.metallic == 1.0 || s.metallic == 0.0, "{}: metallic 0 or 1 only", s.name);
    let normals: Vec<DVec3> = pixels.iter().map(|p| p.1).collect();
    let views: Vec<DVec3> = normals.iter().map(|&n| (camera - (s.centre + s.radius * n)).normalize()).collect();
    let mirror: Vec<DVec3> = normals.iter().zip(&views).map(|(&n, &v)| 2.0 * n.dot(v) * n - v).collect();
    let irradiance: Vec<[f64; 3]> = normals.iter().map(|n| poly.irradiance(n.to_array())).collect();
    let as_arrays: Vec<[f64; 3]> = normals.iter().map(|n| n.to_array()).collect();
    let diffuse: Vec<[f64; 3]> = irradiance_exact(&map.full, &as_arrays).iter().map(|e| e.map(|c| c / PI)).collect();
    let mut out =
        SphereReference { pixels: pixels.iter().map(|p| p.0).collect(), engine: Vec::new(), exact: Vec::new() };
    if s.metallic == 0.0 {
        out.engine = irradiance;
        out.exact = diffuse;
        return out;
    }
    let alpha_g = s.roughness * s.roughness + MINIMUM_VARIANCE;
    let lod = shader_lod(s.roughness, chain);
    let base = (lod.floor() as usize).min(levels - 1);
    let f = if base == levels - 1 { 0.0 } else { lod - base as f64 };
    let mut blended = level_values(map, base, chain, &mirror);
    if f > 0.0 {
        for (b, next) in blended.iter_mut().zip(level_values(map, base + 1, chain, &mirror)) {
            for c in 0..3 {
                b[c] = (1.0 - f) * b[c] + f * next[c];
            }
        }
    }
    let pts = points(LobeSequence::Sobol, 1024);
    let single: Vec<[f64; 3]> = if s.roughness == 0.0 {
        mirror.iter().map(|&d| lookup(&map.full, d)).collect()
    } else {
        let texels = Texels::from_latlong(&map.for_ggx);
        specular(&texels, &normals, &views, s.roughness.powi(2), [1.0; 3])
    };
    for (i, n) in normals.iter().enumerate() {
        out.engine.push([0, 1, 2].map(|k| (1.0 - alpha_g) * blended[i][k] + alpha_g * irradiance[i][k]));
        let nov = n.dot(views[i]).clamp(0.0, 1.0);
        let ess = if s.roughness == 0.0 { 1.0 } else { dfg(nov, s.roughness, &pts, false).iter().sum::<f64>() };
        out.exact.push([0, 1, 2].map(|k| single[i][k] + (1.0 - ess) * diffuse[i][k]));
    }
    out
}

#[test]
fn the_shader_reads_level_l_where_babylons_filter_put_alpha_l() {
    // alphaG_k = 2^(k / 0.8) / 256 is read back at lod k (without the minimum variance).
    let env = Levels::env(256);
    assert_eq!(env.count, 9);
    for k in 1..7 {
        let alpha: f64 = 2f64.powf(k as f64 / env.lod_scale) / 256.0;
        let r = (alpha - MINIMUM_VARIANCE).sqrt();
        assert!((shader_lod(r, env) - k as f64).abs() < 1e-9, "{k}");
    }
    assert_eq!(shader_lod(0.0, env), 0.0);
    assert!((shader_lod(1.0, env) - 6.4).abs() < 1e-3);
    // A glTF light of 256 down to 16: lodGenerationScale 0.5, roughness 1 at the last level.
    let gltf = Levels::gltf(256, 5);
    assert_eq!(gltf.lod_scale, 0.5);
    assert!((shader_lod(1.0, gltf) - 4.0).abs() < 1e-3);
}
