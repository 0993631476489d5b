//! What each sphere pixel should be under the map when Filament 1.53.4 renders it with gltfio's
//! ubershader (the fragment shader the page records, `shaders.txt`; Filament's
//! shaders/src/surface_light_indirect.fs, `evaluateIBL`), in two forms:
//!
//! - `engine`: Filament's own formula with every texture lookup replaced by its exact value.
//!   Per pixel (normal n, view v = +Z: Filament's orthographic view vector is the camera's axis):
//!   1. geometric specular anti-aliasing (`specularAntiAliasing : true`, variance 0.15, threshold
//!      0.2, pinned by the page): `alpha'^2 = alpha^2 + min(2 variance (|dn/dx|^2 + |dn/dy|^2),
//!      threshold^2)` with the normal's derivatives per pixel, here analytic for an orthographic
//!      sphere, `|dn/dx|^2 + |dn/dy|^2 = (p / R)^2 (2 + (nx^2 + ny^2) / nz^2)` (p the pixel size, R
//!      the radius), then `r' = clamp(alpha'^(1/2), 0.089, 1)` (the web build's
//!      `MIN_PERCEPTUAL_ROUGHNESS`: the "mirror" is never sharper than 0.089);
//!   2. the lookup direction `mix(reflect(-v, n), n, alpha'^2)` and the level
//!      `lod = 4 r' (2 - r')` of the 5-level chain, read trilinearly: `(1 - f) P_k + f P_k+1`,
//!      `k = floor(lod)`, where `P_0` is the map itself (bilinear) and `P_k` the exact GGX
//!      prefiltered radiance (`ggx_reference::prefiltered`) at level k's roughness
//!      `1 - sqrt(1 - k / 4)` (what a correct chain holds there);
//!   3. `E = mix(dfg.x, dfg.y, f0)` from the exact multiscatter DFG (`ggx::dfg(.., true)`, 1024
//!      Sobol points; Filament reads a built-in 128 x 128 table of the same integral), the
//!      specular term `E (1 + f0 (1 / dfg.y - 1)) P` (Filament's energy compensation: for the
//!      white metals, f0 = 1, exactly `P`), plus for the dielectric (f0 = 0.04, diffuse colour 1)
//!      `(1 - E) max(SH(n), 0)` with the exact 9 pre-scaled SH of the map (`maths::ibl::sh::project`,
//!      `sh_filament::prescaled`). Ambient occlusion is 1 (no texture, no SSAO), so the
//!      specular AO term is 1.
//!
//!   A correct bake differs from it by the bake's own error, R11F_G11F_B10F rounding, texture
//!   filtering and the DFG table: this is what the test asserts.
//! - `split`: the same formula with the chain's two-level blend replaced by the exact prefiltered
//!   radiance at the pixel's own roughness r': what an infinitely fine chain would give, so
//!   `engine` against `split` is the cost of 5 levels read trilinearly, `split` against `exact`
//!   the split-sum approximation. Reported, not asserted.
//! - `exact`: the material itself, without the split sum, the roughness clamp or the
//!   anti-aliasing: the single-scattering GGX integral at the nominal roughness
//!   (`ggx_reference::specular`, Schlick Fresnel of f0, Smith height-correlated) times Filament's
//!   energy compensation `1 + f0 (1 / E_ss - 1)` with the exact `E_ss`; the mirror's exact value is
//!   the map in the mirror direction; the dielectric adds `(1 - E) E_irr / pi` with the exact
//!   irradiance. Reported, not asserted.
//!
//! Directions are Filament's world directions, which the Filament preset makes hdrflow's own
//! (+Y up, -Z forward: the map's centre).

use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::maths::brdf::ggx::{dfg, points, LobeSequence};
use hdrflow::maths::ibl::ggx_reference::{prefiltered, specular};
use hdrflow::maths::ibl::irradiance_cube::Texels;
use hdrflow::maths::render::reference::irradiance_exact;
use rayon::prelude::*;

use super::reference::{lookup, Map};
use super::scene::{Geometry, Sphere};

/// The chain's levels (cmgen's 256 down to 16).
pub const LEVELS: usize = 5;
/// Filament's smallest perceptual roughness in the web (mobile) build
/// (`MIN_PERCEPTUAL_ROUGHNESS`, the `clamp(.., 0.089, 1.0)` of the recorded shader).
pub const MIN_PERCEPTUAL_ROUGHNESS: f64 = 0.089;
/// gltfio's `specularAntiAliasing` parameters (Filament's material defaults, pinned by the page).
pub const SPECULAR_AA: [f64; 2] = [0.15, 0.2];
/// F0 of a glTF dielectric (IOR 1.5).
const F0_DIELECTRIC: f64 = 0.04;

/// The perceptual roughness of chain level `k` (`RoughnessMap::Filament`).
pub fn level_roughness(k: usize) -> f64 {
    1.0 - (1.0 - k as f64 / (LEVELS - 1) as f64).sqrt()
}

/// The references of one sphere at its chosen pixels.
pub struct SphereReference {
    pub pixels: Vec<usize>,
    pub engine: Vec<[f64; 3]>,
    pub split: Vec<[f64; 3]>,
    pub exact: Vec<[f64; 3]>,
}

/// Filament's pixel roughness after specular anti-aliasing and the clamp (step 1 of the module
/// doc) for normal `n` of a sphere of `radius`, pixels of `pixel_size`.
pub fn shaded_roughness(roughness: f64, n: DVec3, radius: f64, pixel_size: f64) -> f64 {
    let nz2 = (n.z * n.z).max(1e-6);
    let slope = (pixel_size / radius).powi(2) * (2.0 + (n.x * n.x + n.y * n.y) / nz2);
    let [variance, threshold] = SPECULAR_AA;
    let kernel = (2.0 * variance * slope).min(threshold * threshold);
    let alpha2 = (roughness.powi(4) + kernel).clamp(0.0, 1.0);
    alpha2.powf(0.25).clamp(MIN_PERCEPTUAL_ROUGHNESS, 1.0)
}

/// The exact content of chain level `k` in each direction of `dirs`.
fn level_values(map: &Map, k: usize, dirs: &[DVec3]) -> Vec<[f64; 3]> {
    if dirs.is_empty() {
        return Vec::new();
    }
    if k == 0 {
        return dirs.iter().map(|&d| lookup(&map.full, d)).collect();
    }
    let alpha = level_roughness(k).powi(2);
    // Level 1 (alpha 0.018, about a degree) needs the map's own texels; wider lobes the copy's.
    let env = if alpha < 0.05 { &map.full } else { &map.for_ggx };
    prefiltered(&Texels::from_latlong(env), dirs, alpha)
}

/// The references of sphere `s` of `geometry` at `pixels` (index, unit normal), seen along +Z,
/// `sh` the exact pre-scaled SH of the map.
pub fn sphere_reference(
    map: &Map,
    geometry: &Geometry,
    s: &Sphere,
    pixels: &[(usize, DVec3)],
    sh: &[[f64; 3]; 9],
) -> SphereReference {
    let v = DVec3::Z;
    let pts = points(LobeSequence::Sobol, 1024);
    let normals: Vec<DVec3> = pixels.iter().map(|p| p.1).collect();
    let f0 = if s.metallic == 1.0 { 1.0 } else { F0_DIELECTRIC };
    assert!(s.metallic == 1.0 || s.metallic == 0.0, "{}: metallic 0 or 1 only", s.name);

    // Steps 1-2: roughness, direction, level per pixel.
    let shading: Vec<(f64, DVec3, f64)> = normals
        .iter()
        .map(|&n| {
            let r = shaded_roughness(s.roughness, n, s.radius, geometry.pixel_size);
            let mirror = 2.0 * n.dot(v) * n - v;
            let a2 = r.powi(4);
            let dir = (mirror + (n - mirror) * a2).normalize();
            (r, dir, (LEVELS - 1) as f64 * r * (2.0 - r))
        })
        .collect();
    let mut blended = vec![[0.0f64; 3]; normals.len()];
    for k in 0..LEVELS {
        // Pixels reading level k, with their weight.
        let users: Vec<(usize, f64)> = shading
            .iter()
            .enumerate()
            .filter_map(|(i, &(_, _, lod))| {
                let base = (lod.floor() as usize).min(LEVELS - 1);
                let f = if base == LEVELS - 1 { 0.0 } else { lod - base as f64 };
                let w = if k == base {
                    1.0 - f
                } else if k == base + 1 {
                    f
                } else {
                    0.0
                };
                (w > 0.0).then_some((i, w))
            })
            .collect();
        let dirs: Vec<DVec3> = users.iter().map(|&(i, _)| shading[i].1).collect();
        for ((i, w), val) in users.iter().zip(level_values(map, k, &dirs)) {
            for c in 0..3 {
                blended[*i][c] += w * val[c];
            }
        }
    }

    // The split sum at each pixel's own roughness (one lobe per pixel: r' varies on the mirror).
    let (full, small) = (Texels::from_latlong(&map.full), Texels::from_latlong(&map.for_ggx));
    let own: Vec<[f64; 3]> = shading
        .par_iter()
        .map(|&(r, dir, _)| {
            let alpha = r * r;
            prefiltered(if alpha < 0.05 { &full } else { &small }, &[dir], alpha)[0]
        })
        .collect();

    // The exact integrals.
    let as_arrays: Vec<[f64; 3]> = normals.iter().map(|n| n.to_array()).collect();
    let irradiance: Vec<[f64; 3]> = if f0 < 1.0 { irradiance_exact(&map.full, &as_arrays) } else { Vec::new() };
    let single: Vec<[f64; 3]> = if s.roughness == 0.0 {
        normals.iter().map(|&n| lookup(&map.full, 2.0 * n.dot(v) * n - v)).collect()
    } else {
        let views = vec![v; normals.len()];
        specular(&small, &normals, &views, s.roughness.powi(2), [f0; 3])
    };

    let mut out = SphereReference {
        pixels: pixels.iter().map(|p| p.0).collect(),
        engine: Vec::new(),
        split: Vec::new(),
        exact: Vec::new(),
    };
    for (i, &n) in normals.iter().enumerate() {
        let nov = n.dot(v).max(1e-4);
        // Step 3 at the shaded roughness.
        let [x, y] = dfg(nov, shading[i].0, &pts, true);
        let e = x + (y - x) * f0;
        let compensation = 1.0 + f0 * (1.0 / y - 1.0);
        let mut engine = blended[i].map(|c| c * e * compensation);
        let mut split = own[i].map(|c| c * e * compensation);
        // The exact material at the nominal roughness.
        let (ex, ey) = if s.roughness == 0.0 {
            (0.0, 1.0)
        } else {
            let [a, b] = dfg(nov, s.roughness, &pts, true);
            (a, b)
        };
        let e_exact = ex + (ey - ex) * f0;
        let mut exact = single[i].map(|c| c * (1.0 + f0 * (1.0 / ey - 1.0)));
        if f0 < 1.0 {
            let sh_value = hdrflow::maths::ibl::sh_filament::evaluate(sh, n.to_array()).map(|c| c.max(0.0));
            for c in 0..3 {
                engine[c] += (1.0 - e) * sh_value[c];
                split[c] += (1.0 - e) * sh_value[c];
                exact[c] += (1.0 - e_exact) * irradiance[i][c] / PI;
            }
        }
        out.engine.push(engine);
        out.split.push(split);
        out.exact.push(exact);
    }
    out
}

#[test]
fn shaded_roughness_follows_the_clamp_and_the_anti_aliasing_kernel() {
    // The sphere's centre: slope 2 (p / R)^2, kernel 0.6 (p / R)^2.
    let (p, r) = (6.0 / 768.0, 0.45);
    let kernel = 0.3 * 2.0 * (p / r) * (p / r);
    let got = shaded_roughness(0.0, DVec3::Z, r, p);
    assert!((got - kernel.powf(0.25)).abs() < 1e-12, "{got}");
    assert!(got > MIN_PERCEPTUAL_ROUGHNESS);
    // A rough sphere barely moves; without a kernel a smooth one clamps at 0.089.
    assert!((shaded_roughness(0.5, DVec3::Z, r, p) - 0.5).abs() < 2e-3);
    assert_eq!(shaded_roughness(0.0, DVec3::Z, 1e9, p), MIN_PERCEPTUAL_ROUGHNESS);
    // Level roughness inverts lod = 4 r (2 - r) at whole levels.
    for k in 0..LEVELS {
        let r = level_roughness(k);
        assert!((4.0 * r * (2.0 - r) - k as f64).abs() < 1e-12);
    }
}
