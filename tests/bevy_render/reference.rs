//! What each sphere pixel should be under the map, from exact sums over the map's texels
//! (`hdrflow::maths::render::reference`, `hdrflow::maths::ibl::ggx_reference`), in two forms:
//!
//! - `engine`: Bevy's own shading formula (`scene::lookup_weights`, its dominant direction) with
//!   each cube-map lookup replaced by its exact value: the specular map by the exact GGX
//!   prefiltered radiance (`n = v = r`, the split sum's first factor) at the roughness Bevy asks
//!   for, the mirror's level 0 by a bilinear lookup of the map, the diffuse map by `E(n) / pi`.
//!   A correct bake differs from it only by the bake's own error, Bevy's texture filtering and the
//!   frame's f16 rounding: this is what the test asserts.
//! - `exact`: the GGX microfacet integral itself (single scattering, F0 = 1 so Fresnel is 1, Smith
//!   height-correlated visibility, the exact mirror direction), plus the energy single scattering
//!   loses, `(1 - E_ss(n.v)) E / pi`, the multiscattering model Bevy uses (Fdez-Aguera 2019, F0 = 1)
//!   with the exact directional albedo `E_ss` (`ggx::dfg`, 1024 Sobol points) where Bevy has Karis'
//!   polynomial: the difference to `engine` is the split-sum approximation (reported, not
//!   asserted). `single` is the single-scattering integral alone.
//!
//! Directions are Bevy's world directions, which the Bevy bake makes hdrflow's own (+Y up, -Z
//! forward: the map's centre).

use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::maths::brdf::ggx::{dfg, points, LobeSequence};
use hdrflow::maths::ibl::ggx_reference::{prefiltered, specular};
use hdrflow::maths::ibl::irradiance_cube::Texels;
use hdrflow::maths::render::reference::irradiance_exact;
use hdrflow::maths::resample::bilinear;
use hdrflow::values::Image;

use super::scene::{lookup_weights, shader_alpha, specular_direction, Sphere};

/// The references of one sphere at its chosen pixels.
pub struct SphereReference {
    pub pixels: Vec<usize>,
    pub engine: Vec<[f64; 3]>,
    pub exact: Vec<[f64; 3]>,
    pub single: Vec<[f64; 3]>,
}

/// The map twice: as it is (mirror lookups, irradiance) and smaller for the GGX sums, whose
/// lobes span many of its texels (`ggx_reference`'s condition); a 512 x 256 copy has 0.7-degree
/// texels, against a half width of about 5 degrees for the narrowest lobe (roughness 0.25).
pub struct Map {
    pub full: Image,
    pub for_ggx: Image,
}

impl Map {
    pub fn new(full: Image) -> Map {
        let for_ggx = if full.width > 512 {
            hdrflow::maths::resample::area_resize::resize(&full, 512, 256)
        } else {
            full.clone()
        };
        Map { full, for_ggx }
    }
}

/// A bilinear lookup of the lat-long map in direction `d`, as RGB (grey for one channel).
pub fn lookup(env: &Image, d: DVec3) -> [f64; 3] {
    let mut out = vec![0.0; env.channels];
    bilinear::latlong(env, d, &mut out);
    if env.channels < 3 {
        [out[0]; 3]
    } else {
        [out[0], out[1], out[2]]
    }
}

/// The references of sphere `s` at `pixels` (index, unit normal), seen along +Z.
pub fn sphere_reference(map: &Map, s: &Sphere, pixels: &[(usize, DVec3)]) -> SphereReference {
    let v = DVec3::Z;
    let normals: Vec<DVec3> = pixels.iter().map(|p| p.1).collect();
    let as_arrays: Vec<[f64; 3]> = normals.iter().map(|n| n.to_array()).collect();
    let diffuse: Vec<[f64; 3]> = irradiance_exact(&map.full, &as_arrays).iter().map(|e| e.map(|c| c / PI)).collect();
    let mirror: Vec<DVec3> = normals.iter().map(|&n| 2.0 * n.dot(v) * n - v).collect();
    let engine_dirs: Vec<DVec3> =
        normals.iter().zip(&mirror).map(|(&n, &r)| specular_direction(n, r, shader_alpha(s.roughness))).collect();

    let (spec_engine, single): (Vec<[f64; 3]>, Vec<[f64; 3]>) = if s.metallic == 0.0 {
        (vec![[0.0; 3]; normals.len()], vec![[0.0; 3]; normals.len()])
    } else if s.roughness == 0.0 {
        (
            engine_dirs.iter().map(|&d| lookup(&map.full, d)).collect(),
            mirror.iter().map(|&d| lookup(&map.full, d)).collect(),
        )
    } else {
        let texels = Texels::from_latlong(&map.for_ggx);
        let alpha = s.roughness * s.roughness;
        let views = vec![v; normals.len()];
        (prefiltered(&texels, &engine_dirs, alpha), specular(&texels, &normals, &views, alpha, [1.0; 3]))
    };

    let mut out = SphereReference {
        pixels: pixels.iter().map(|p| p.0).collect(),
        engine: Vec::new(),
        exact: Vec::new(),
        single: Vec::new(),
    };
    let pts = points(LobeSequence::Sobol, 1024);
    for (i, n) in normals.iter().enumerate() {
        let nov = n.dot(v);
        let (ws, wd) = lookup_weights(s, nov);
        out.engine.push([0, 1, 2].map(|k| ws * spec_engine[i][k] + wd * diffuse[i][k]));
        if s.metallic == 0.0 {
            // A Lambertian sphere's shading is exact as it is (its specular weight is 0).
            out.exact.push(diffuse[i].map(|c| c * wd));
            out.single.push([0.0; 3]);
        } else {
            let ess = if s.roughness == 0.0 { 1.0 } else { dfg(nov, s.roughness, &pts, false).iter().sum::<f64>() };
            out.exact.push([0, 1, 2].map(|k| single[i][k] + (1.0 - ess) * diffuse[i][k]));
            out.single.push(single[i]);
        }
    }
    out
}

/// `sqrt(sum (frame - reference)^2 / sum reference^2)` over the pixels and the RGB channels, the
/// frame divided by `scale` (Bevy's intensity times exposure).
pub fn relative_rmse(frame: &Image, scale: f64, pixels: &[usize], reference: &[[f64; 3]]) -> f64 {
    let (mut err, mut norm) = (0.0, 0.0);
    for (&p, r) in pixels.iter().zip(reference) {
        let got = &frame.data[p * frame.channels..p * frame.channels + 3];
        for k in 0..3 {
            let d = got[k] as f64 / scale - r[k];
            err += d * d;
            norm += r[k] * r[k];
        }
    }
    (err / norm.max(f64::MIN_POSITIVE)).sqrt()
}

/// Bilinear, seamless lookup of a cube level (`values` per texel, face-major) at direction `d`:
/// how the web engines' samplers read a prefiltered level (the Khronos and Babylon references).
#[allow(dead_code)] // the Bevy test itself reads levels through `scene`'s lookups
pub fn cube_bilinear(values: &[[f64; 3]], size: usize, d: DVec3) -> [f64; 3] {
    use hdrflow::geometry::cubemap as cube;
    let (f, a, b) = cube::direction_to_face(d);
    let fx = (a + 1.0) * 0.5 * size as f64 - 0.5;
    let fy = (b + 1.0) * 0.5 * size as f64 - 0.5;
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let at = |x: i64, y: i64| values[cube::seamless_texel_index(f, x, y, size)];
    let (v00, v10, v01, v11) = (at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1));
    [0, 1, 2].map(|k| (v00[k] * (1.0 - tx) + v10[k] * tx) * (1.0 - ty) + (v01[k] * (1.0 - tx) + v11[k] * tx) * ty)
}

/// A sphere's pixels with the two references of the web engines' tests (tests/babylon_render,
/// tests/gltf_render, tests/playcanvas_render): the engine's formula fed exact values, and the
/// exact material.
#[allow(dead_code)] // the web engines' tests, not Bevy's
pub struct EngineReference {
    pub pixels: Vec<usize>,
    pub engine: Vec<[f64; 3]>,
    pub exact: Vec<[f64; 3]>,
}

/// Relative RMSE per sphere of `frame` against the `engine` references of `engine_name`'s formula,
/// printed under `label` with the error against the exact ones and four pixels a sphere.
#[allow(dead_code)] // the web engines' tests, not Bevy's
pub fn engine_errors(
    label: &str,
    engine_name: &str,
    frame: &Image,
    spheres: &[Sphere],
    refs: &[EngineReference],
) -> Vec<f64> {
    eprintln!(
        "{label}: relative RMSE per sphere (vs {engine_name} formula on exact lookups | vs exact GGX and irradiance)"
    );
    let mut out = Vec::new();
    for (s, r) in spheres.iter().zip(refs) {
        let e = relative_rmse(frame, 1.0, &r.pixels, &r.engine);
        let x = relative_rmse(frame, 1.0, &r.pixels, &r.exact);
        eprintln!("  {:<11} {:>8.4} | {:>8.4}   ({} pixels)", s.name, e, x, r.pixels.len());
        for q in [0, r.pixels.len() / 3, r.pixels.len() / 2, r.pixels.len() - 1] {
            let p = r.pixels[q];
            eprintln!(
                "     px {p}: got {:?} engine {:?} exact {:?}",
                &frame.data[p * 4..p * 4 + 3],
                r.engine[q],
                r.exact[q]
            );
        }
        out.push(e);
    }
    out
}
