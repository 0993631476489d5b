//! The client's scene as it declares it (`--geometry` JSON), the pixels of each sphere with their
//! normals, and the few lines of Bevy 0.19.1's shader that turn the two cube-map lookups into a
//! pixel (`bevy_pbr/src/light_probe/environment_map.wgsl`, `render/pbr_lighting.wgsl`,
//! `render/pbr_functions.wgsl`), so the reference can apply the same weights to exact lookups.

use std::path::Path;

use glam::DVec3;
use serde_json::Value as Json;

/// One sphere of the scene.
#[derive(Debug, Clone)]
pub struct Sphere {
    pub name: String,
    pub centre: DVec3,
    pub radius: f64,
    pub metallic: f64,
    pub roughness: f64,
    pub reflectance: f64,
}

/// The scene: an orthographic camera looking down -Z (view direction +Z at every pixel).
#[derive(Debug, Clone)]
pub struct Geometry {
    pub width: usize,
    pub height: usize,
    pub pixel_size: f64,
    /// Bevy's exposure factor `2^-ev100 / 1.2` (1 to f32 rounding)
    pub exposure: f64,
    pub intensity: f64,
    pub spheres: Vec<Sphere>,
}

fn num(j: &Json, key: &str) -> f64 {
    j[key].as_f64().unwrap_or_else(|| panic!("geometry: {key} is not a number in {j}"))
}

fn vec3(j: &Json, key: &str) -> DVec3 {
    let a: Vec<f64> = j[key].as_array().map(|a| a.iter().filter_map(Json::as_f64).collect()).unwrap_or_default();
    assert_eq!(a.len(), 3, "geometry: {key} is not 3 numbers in {j}");
    DVec3::new(a[0], a[1], a[2])
}

impl Geometry {
    /// The names of the spheres whose error (in `spheres` order) is above its bound.
    pub fn failing(&self, errors: &[f64], bounds: &[f64]) -> Vec<String> {
        self.spheres
            .iter()
            .zip(errors.iter().zip(bounds))
            .filter(|(_, (e, b))| e > b)
            .map(|(s, _)| s.name.clone())
            .collect()
    }

    /// The spheres of `must_fail` that the mistake `name`'s per-sphere `errors` leave within
    /// `bounds`, one line each for the failure message: what the comparison did not catch.
    pub fn missed(&self, name: &str, errors: &[f64], bounds: &[f64], must_fail: &[&str]) -> Vec<String> {
        let failed = self.failing(errors, bounds);
        must_fail
            .iter()
            .filter(|s| !failed.iter().any(|f| f == *s))
            .map(|s| format!("{name}: {s} passed the comparison (failing: {failed:?})"))
            .collect()
    }

    pub fn read(path: &Path) -> Geometry {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
        let j: Json = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()));
        assert_eq!(j["projection"], "orthographic", "{text}");
        assert_eq!(vec3(&j, "view_direction"), DVec3::Z, "{text}");
        let spheres = j["spheres"]
            .as_array()
            .expect("spheres")
            .iter()
            .map(|s| Sphere {
                name: s["name"].as_str().expect("name").to_string(),
                centre: vec3(s, "centre"),
                radius: num(s, "radius"),
                metallic: num(s, "metallic"),
                roughness: num(s, "perceptual_roughness"),
                reflectance: num(s, "reflectance"),
            })
            .collect();
        Geometry {
            width: num(&j, "width") as usize,
            height: num(&j, "height") as usize,
            pixel_size: num(&j, "pixel_size"),
            exposure: num(&j, "exposure"),
            intensity: num(&j, "intensity"),
            spheres,
        }
    }

    /// The pixels of sphere `k` whose centre lies within `inner` of its radius (the silhouette's
    /// pixels, partly covered and shaded from the mesh's facets, are left out), every `step`-th
    /// column and row: (pixel index, unit normal).
    pub fn pixels(&self, k: usize, inner: f64, step: usize) -> Vec<(usize, DVec3)> {
        let s = &self.spheres[k];
        let mut out = Vec::new();
        for j in (0..self.height).step_by(step) {
            for i in (0..self.width).step_by(step) {
                let x = (i as f64 + 0.5 - self.width as f64 / 2.0) * self.pixel_size;
                let y = (self.height as f64 / 2.0 - j as f64 - 0.5) * self.pixel_size;
                let (dx, dy) = ((x - s.centre.x) / s.radius, (y - s.centre.y) / s.radius);
                let rr = dx * dx + dy * dy;
                if rr <= inner * inner {
                    out.push((j * self.width + i, DVec3::new(dx, dy, (1.0 - rr).sqrt())));
                }
            }
        }
        out
    }
}

/// The skybox view (`--skybox X,Y,Z`): a perspective camera at the origin looking along
/// `forward` with +Y up, the specular map drawn as Bevy's `Skybox`.
#[derive(Debug, Clone)]
pub struct SkyView {
    pub width: usize,
    pub height: usize,
    pub forward: DVec3,
    pub fov_y_degrees: f64,
}

impl SkyView {
    pub fn read(path: &Path) -> SkyView {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
        let j: Json = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()));
        assert_eq!(j["projection"], "perspective", "{text}");
        assert_eq!(vec3(&j, "up"), DVec3::Y, "{text}");
        assert_eq!(vec3(&j, "camera_position"), DVec3::ZERO, "{text}");
        // Pixels are Bevy's exposure factor times the map: 1 here, as for the spheres.
        assert!((num(&j, "exposure") * num(&j, "intensity") - 1.0).abs() < 1e-6, "{text}");
        SkyView {
            width: num(&j, "width") as usize,
            height: num(&j, "height") as usize,
            forward: vec3(&j, "forward"),
            fov_y_degrees: num(&j, "fov_y_degrees"),
        }
    }
}

/// `F_AB` without the DFG texture (Bevy's `dfg_lut` feature is off by default): Karis' polynomial
/// fit of the split-sum DFG term ("Physically Based Shading on Mobile", 2014), kept positive.
pub fn f_ab(perceptual_roughness: f64, nov: f64) -> [f64; 2] {
    let c0 = [-1.0, -0.0275, -0.572, 0.022];
    let c1 = [1.0, 0.0425, 1.04, -0.04];
    let r: Vec<f64> = (0..4).map(|k| perceptual_roughness * c0[k] + c1[k]).collect();
    let a004 = (r[0] * r[0]).min((-9.28 * nov).exp2()) * r[0] + r[1];
    [(-1.04 * a004 + r[2]).max(0.00005), (1.04 * a004 + r[3]).max(0.00005)]
}

/// `perceptualRoughnessToRoughness`: alpha from the clamped perceptual roughness.
pub fn shader_alpha(perceptual_roughness: f64) -> f64 {
    let r = perceptual_roughness.clamp(0.089, 1.0);
    r * r
}

/// `radiance_sample_direction`: where the specular map is read, between the normal and the mirror
/// direction (Frostbite's dominant direction), normalised here (the cube lookup ignores length).
pub fn specular_direction(n: DVec3, r: DVec3, alpha: f64) -> DVec3 {
    let smoothness = (1.0 - alpha).clamp(0.0, 1.0);
    let lerp = smoothness * (smoothness.sqrt() + alpha);
    (n + (r - n) * lerp).normalize()
}

/// The weights of the two lookups for a white base colour: pixel = `specular` x the specular
/// map's value + `diffuse` x the diffuse map's value (both times `intensity`), from
/// `environment_map_light` with its multiscattering term (Fdez-Aguera 2019) and "specular
/// occlusion" `saturate(50 * 0.33 * sum(F0))`.
pub fn lookup_weights(s: &Sphere, nov: f64) -> (f64, f64) {
    let nov = nov.max(0.0001);
    let f0_dielectric = 0.16 * s.reflectance * s.reflectance;
    let f0_metallic = 1.0;
    let f0_surface = f0_dielectric + (f0_metallic - f0_dielectric) * s.metallic;
    let occlusion = (3.0 * f0_surface * 50.0 * 0.33).clamp(0.0, 1.0);
    let [a, b] = f_ab(s.roughness, nov);
    let ems = 1.0 - (a + b);
    let multiscatter = |f0: f64| {
        let fss_ess = (f0 * a + b) * occlusion;
        let f_avg = f0 + (1.0 - f0) / 21.0;
        let fms_ems = fss_ess * f_avg / (1.0 - ems * f_avg) * ems;
        (fss_ess, fms_ems, 1.0 - (fss_ess + fms_ems))
    };
    let (d_ss, d_ms, d_edss) = multiscatter(f0_dielectric);
    let (m_ss, m_ms, _) = multiscatter(f0_metallic);
    let mix = |x: f64, y: f64| x + (y - x) * s.metallic;
    let diffuse_colour = 1.0 - s.metallic;
    (mix(d_ss, m_ss), mix(d_ms, m_ms) + diffuse_colour * d_edss)
}

#[test]
fn lookup_weights_of_the_scene_materials() {
    let sphere = |metallic, roughness, reflectance| Sphere {
        name: String::new(),
        centre: DVec3::ZERO,
        radius: 1.0,
        metallic,
        roughness,
        reflectance,
    };
    // A white metal: F_AB sums to 1 - 0.55 r (the polynomial's x and z terms cancel), the rest of
    // the energy comes back through the diffuse map (multiscattering with F0 = 1).
    for r in [0.0, 0.25, 0.5, 0.75] {
        let (s, d) = lookup_weights(&sphere(1.0, r, 0.5), 0.7);
        assert!((s - (1.0 - 0.55 * r)).abs() < 1e-12 && (s + d - 1.0).abs() < 1e-12, "r {r}: {s} {d}");
    }
    // The diffuse sphere (reflectance 0): no specular at all, the diffuse map as it is.
    assert_eq!(lookup_weights(&sphere(0.0, 1.0, 0.0), 0.3), (0.0, 1.0));
}
