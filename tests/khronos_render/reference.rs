//! What each sphere pixel should be when the Khronos glTF Sample Renderer 1.1.0 renders it lit by
//! a Khronos bake (the fragment shader the page records, `shaders.txt`; glTF-Sample-Renderer
//! `source/Renderer/shaders/pbr.frag`, `ibl.glsl`), in two forms:
//!
//! - `engine`: the renderer's formula with every texture lookup replaced by its exact value. Per
//!   pixel (normal n, surface point p, the view vector `v = normalize(camera - p)`: the renderer
//!   takes it from the camera's position also for an orthographic camera):
//!   1. the lookup direction `reflect(-v, n)` (no dominant-direction bend) and the level
//!      `lod = r (N - 1)` of the N-level chain, read trilinearly: `(1 - f) P_k + f P_k+1`, where
//!      `P_0` is the map itself (bilinear) and `P_k` the exact GGX prefiltered radiance
//!      (`ggx_reference::prefiltered`) at level k's roughness `k / (N - 1)` (`RoughnessMap::Linear`:
//!      what a correct chain holds there). On the coarse levels (faces of at most 16 texels; the
//!      chain goes down to 1 x 1) a texel spans more than the lobe varies over, so there `P_k` is
//!      what the GPU reads of a perfect level: the exact values at the level's texel centres,
//!      interpolated bilinearly and seamlessly across face edges (`geometry::cubemap`, the
//!      bake's own face layout);
//!   2. `getIBLGGXFresnel(n, v, r, F0, 1)`: with the exact split-sum terms (A, B) (`ggx::dfg`, 1024
//!      Sobol points; the renderer reads the bake's `lut_ggx.png`),
//!      `k_S = F0 + (max(1 - r, F0) - F0) (1 - n.v)^5`, `FssEss = k_S A + B`,
//!      `Ems = 1 - (A + B)`, `F_avg = F0 + (1 - F0) / 21`, `F = FssEss + Ems FssEss F_avg / (1 - F_avg Ems)`;
//!      for the white metals (F0 = 1) F is exactly 1;
//!   3. metal: `F P`; the dielectric (F0 = 0.04, base colour 1): `(1 - F) E(n) / pi + F P`, with
//!      `E(n) / pi` the exact irradiance (`reference::irradiance_exact`) where the renderer reads the
//!      Lambertian cube.
//!
//!   A correct bake differs from it by the bake's own error, RGBA16F rounding, texture filtering
//!   and the LUT's 8 bits: this is what the test asserts.
//! - `exact`: the material without the split sum: the single-scattering GGX integral at the
//!   nominal roughness (`ggx_reference::specular`, F0 = 1, Smith height-correlated) plus the
//!   energy single scattering loses, `(1 - E_ss(n.v)) E / pi` (the renderer's multiple-scattering
//!   term with F0 = 1 restores all of it), the mirror's exact value the map in the mirror
//!   direction; the dielectric's is its `engine` value. Reported, not asserted.
//!
//! Directions are the renderer's world directions at `environmentRotation` 0, which the Khronos
//! preset makes hdrflow's own (+Y up, -Z forward: the map's centre).

use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::geometry::cubemap as cube;
use hdrflow::maths::brdf::ggx::{dfg, points, LobeSequence};
use hdrflow::maths::ibl::ggx_reference::{prefiltered, specular};
use hdrflow::maths::ibl::irradiance_cube::Texels;
use hdrflow::maths::render::reference::irradiance_exact;
use rayon::prelude::*;

use super::reference::{cube_bilinear, lookup, Map};
use super::scene::Sphere;

/// F0 of a glTF dielectric (IOR 1.5).
const F0_DIELECTRIC: f64 = 0.04;

/// The references of one sphere at its chosen pixels.
pub struct SphereReference {
    pub pixels: Vec<usize>,
    pub engine: Vec<[f64; 3]>,
    pub exact: Vec<[f64; 3]>,
}

/// A bake's specular chain: its level 0 face size and level count (down to 1 x 1).
#[derive(Clone, Copy)]
pub struct Chain {
    pub size: usize,
    pub levels: usize,
}

/// Faces this small or smaller are modelled texel by texel (module doc, step 1).
const COARSE: usize = 16;

/// The exact content of level `k` of a `Linear` chain in each direction of `dirs`.
fn level_values(map: &Map, k: usize, chain: Chain, dirs: &[DVec3]) -> Vec<[f64; 3]> {
    if dirs.is_empty() {
        return Vec::new();
    }
    if k == 0 {
        return dirs.iter().map(|&d| lookup(&map.full, d)).collect();
    }
    let alpha = (k as f64 / (chain.levels - 1) as f64).powi(2);
    // The narrow lobes (level 1: alpha 0.016, about a degree) need the map's own texels.
    let env = if alpha < 0.05 { &map.full } else { &map.for_ggx };
    let texels = Texels::from_latlong(env);
    let size = (chain.size >> k).max(1);
    if size <= COARSE {
        let centres: Vec<DVec3> = (0..6)
            .flat_map(|f| (0..size).flat_map(move |y| (0..size).map(move |x| cube::texel_direction(f, x, y, size))))
            .collect();
        let values: Vec<[f64; 3]> = centres.par_chunks(64).flat_map_iter(|c| prefiltered(&texels, c, alpha)).collect();
        return dirs.iter().map(|&d| cube_bilinear(&values, size, d)).collect();
    }
    dirs.par_chunks(64).flat_map_iter(|chunk| prefiltered(&texels, chunk, alpha)).collect()
}

/// The split-sum Fresnel of the renderer (`getIBLGGXFresnel`, specular weight 1).
pub fn ibl_fresnel(nov: f64, roughness: f64, f0: f64, ab: [f64; 2]) -> f64 {
    let [a, b] = ab;
    let k_s = f0 + ((1.0 - roughness).max(f0) - f0) * (1.0 - nov).powi(5);
    let fss_ess = k_s * a + b;
    let ems = 1.0 - (a + b);
    let f_avg = f0 + (1.0 - f0) / 21.0;
    fss_ess + ems * fss_ess * f_avg / (1.0 - f_avg * ems)
}

/// The references of sphere `s` at `pixels` (index, unit normal) seen from an orthographic
/// camera at `camera`, lit by `chain`.
pub fn sphere_reference(
    map: &Map,
    s: &Sphere,
    pixels: &[(usize, DVec3)],
    camera: DVec3,
    chain: Chain,
) -> SphereReference {
    let levels = chain.levels;
    assert!(s.metallic == 1.0 || s.metallic == 0.0, "{}: metallic 0 or 1 only", s.name);
    let pts = points(LobeSequence::Sobol, 1024);
    let normals: Vec<DVec3> = pixels.iter().map(|p| p.1).collect();
    let views: Vec<DVec3> = normals.iter().map(|&n| (camera - (s.centre + s.radius * n)).normalize()).collect();
    let mirror: Vec<DVec3> = normals.iter().zip(&views).map(|(&n, &v)| 2.0 * n.dot(v) * n - v).collect();

    // Step 1: the chain's two levels per pixel.
    let lod = s.roughness * (levels - 1) as f64;
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

    let as_arrays: Vec<[f64; 3]> = normals.iter().map(|n| n.to_array()).collect();
    let diffuse: Vec<[f64; 3]> = irradiance_exact(&map.full, &as_arrays).iter().map(|e| e.map(|c| c / PI)).collect();
    let single: Vec<[f64; 3]> = if s.metallic == 0.0 {
        Vec::new()
    } else if s.roughness == 0.0 {
        mirror.iter().map(|&d| lookup(&map.full, d)).collect()
    } else {
        let texels = Texels::from_latlong(&map.for_ggx);
        specular(&texels, &normals, &views, s.roughness.powi(2), [1.0; 3])
    };

    let mut out =
        SphereReference { pixels: pixels.iter().map(|p| p.0).collect(), engine: Vec::new(), exact: Vec::new() };
    for (i, n) in normals.iter().enumerate() {
        let nov = n.dot(views[i]).clamp(0.0, 1.0);
        if s.metallic == 1.0 {
            out.engine.push(blended[i]);
            let ess = if s.roughness == 0.0 { 1.0 } else { dfg(nov, s.roughness, &pts, false).iter().sum::<f64>() };
            out.exact.push([0, 1, 2].map(|k| single[i][k] + (1.0 - ess) * diffuse[i][k]));
        } else {
            let fresnel = ibl_fresnel(nov, s.roughness, F0_DIELECTRIC, dfg(nov, s.roughness, &pts, false));
            let v = [0, 1, 2].map(|k| (1.0 - fresnel) * diffuse[i][k] + fresnel * blended[i][k]);
            out.engine.push(v);
            out.exact.push(v);
        }
    }
    out
}

#[test]
fn the_renderers_fresnel_is_one_for_a_white_metal_and_f0_at_normal_incidence_without_a_lobe() {
    // F0 = 1: FssEss = A + B, Ems = 1 - (A + B), F_avg = 1, so F = (A + B) + (1 - (A + B)) = 1.
    for ab in [[0.3, 0.1], [0.9, 0.05], [0.5, 0.4]] {
        assert!((ibl_fresnel(0.7, 0.5, 1.0, ab) - 1.0).abs() < 1e-12);
    }
    // A perfectly smooth surface seen head on: A = 1, B = 0, so F = F0 and no energy is missing.
    assert!((ibl_fresnel(1.0, 0.0, 0.04, [1.0, 0.0]) - 0.04).abs() < 1e-12);
}
