//! The fixed scene: six spheres in a row seen by an orthographic camera, declared once here and
//! written to `--geometry` as JSON so that a test can compute, for every pixel, the sphere's
//! normal and the view direction without knowing Bevy.
//!
//! Orthographic, so the view direction (towards the camera) is +Z at every pixel. The camera
//! looks down -Z from (0, 0, 10) with +Y up; the image spans `6 x 6 H / W` world units, centred
//! on the origin, so one world unit is `W / 6` pixels and pixel (i, j) (row 0 at the top) sees
//! the world point `x = (i + 0.5 - W / 2) s`, `y = (H / 2 - j - 0.5) s`, `s = 6 / W`. Sphere k
//! (0..6) has centre `(k - 2.5, 0, 0)` and radius 0.45.

use std::fmt::Write;

use bevy::light::DirectionalLight;
use bevy::prelude::Transform;

/// World units across the image: one per sphere.
pub const VIEW_WIDTH: f32 = 6.0;
/// Sphere radius in world units (cells are 1 unit wide: a margin of 0.05 each side).
pub const RADIUS: f32 = 0.45;
/// Camera position on +Z (any distance works for an orthographic camera; the spheres lie
/// between the near and far planes).
pub const CAMERA_Z: f32 = 10.0;

/// The skybox view's vertical field of view (`--skybox`), degrees: a pixel (i, j) of a W x H frame
/// looks along `forward + right (2 (i + 0.5) / W - 1) t W / H + up (1 - 2 (j + 0.5) / H) t`,
/// t = tan(fov / 2) = 1, `right = forward x up` (Bevy's `looking_to(forward, Y)`).
pub const SKYBOX_FOV_Y_DEG: f32 = 90.0;

/// One sphere's material (Bevy `StandardMaterial`, white base colour in every case).
pub struct SphereSpec {
    pub name: &'static str,
    pub metallic: f32,
    pub perceptual_roughness: f32,
    /// Bevy's dielectric reflectance (F0 = 0.16 reflectance^2): 0 makes the diffuse sphere purely
    /// Lambertian (F0 = 0 also zeroes Bevy's specular occlusion term, so no specular at all).
    pub reflectance: f32,
}

/// The six spheres, left to right: mirror, four rough metals, white Lambertian.
pub const SPHERES: [SphereSpec; 6] = [
    SphereSpec { name: "mirror", metallic: 1.0, perceptual_roughness: 0.0, reflectance: 0.5 },
    SphereSpec { name: "metal_0.25", metallic: 1.0, perceptual_roughness: 0.25, reflectance: 0.5 },
    SphereSpec { name: "metal_0.5", metallic: 1.0, perceptual_roughness: 0.5, reflectance: 0.5 },
    SphereSpec { name: "metal_0.75", metallic: 1.0, perceptual_roughness: 0.75, reflectance: 0.5 },
    SphereSpec { name: "metal_1", metallic: 1.0, perceptual_roughness: 1.0, reflectance: 0.5 },
    SphereSpec { name: "diffuse", metallic: 0.0, perceptual_roughness: 1.0, reflectance: 0.0 },
];

/// Centre x of sphere `k`.
pub fn centre_x(k: usize) -> f32 {
    k as f32 + 0.5 - VIEW_WIDTH / 2.0
}

/// The scene as JSON (hand-written: the client needs no serde). `exposure` is the factor Bevy
/// multiplies every pixel by (`2^-ev100 / 1.2`), `intensity` the `EnvironmentMapLight` one, `suns`
/// the directional lights spawned from the README's sun lines (`"sun"`: null without `--sun`).
pub fn geometry_json(
    width: u32,
    height: u32,
    intensity: f32,
    ev100: f32,
    exposure: f32,
    suns: &[(DirectionalLight, Transform)],
) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "{{\n  \"width\": {width},\n  \"height\": {height},\n  \"projection\": \"orthographic\",\n  \
         \"camera_position\": [0, 0, {CAMERA_Z}],\n  \"view_direction\": [0, 0, 1],\n  \"up\": [0, 1, 0],\n  \
         \"view_width\": {VIEW_WIDTH},\n  \"view_height\": {},\n  \"pixel_size\": {},\n  \
         \"intensity\": {intensity},\n  \"ev100\": {ev100},\n  \"exposure\": {exposure},\n  \"spheres\": [\n",
        VIEW_WIDTH * height as f32 / width as f32,
        VIEW_WIDTH / width as f32,
    );
    for (k, sp) in SPHERES.iter().enumerate() {
        let _ = write!(
            s,
            "    {{\"name\": \"{}\", \"centre\": [{}, 0, 0], \"radius\": {RADIUS}, \"base_color\": [1, 1, 1], \
             \"metallic\": {}, \"perceptual_roughness\": {}, \"reflectance\": {}}}{}\n",
            sp.name,
            centre_x(k),
            sp.metallic,
            sp.perceptual_roughness,
            sp.reflectance,
            if k + 1 < SPHERES.len() { "," } else { "" }
        );
    }
    s.push_str("  ],\n  \"sun\": ");
    if suns.is_empty() {
        s.push_str("null");
    } else {
        let lights: Vec<String> = suns
            .iter()
            .map(|(l, t)| {
                let c = l.color.to_linear();
                let f = t.forward();
                format!(
                    "{{\"illuminance\": {}, \"color\": [{}, {}, {}], \"shadow_maps_enabled\": {}, \
                     \"forward\": [{}, {}, {}]}}",
                    l.illuminance, c.red, c.green, c.blue, l.shadow_maps_enabled, f.x, f.y, f.z
                )
            })
            .collect();
        let _ = write!(s, "[{}]", lights.join(", "));
    }
    s.push_str("\n}\n");
    s
}

/// The skybox view (`--skybox`) as JSON: a perspective camera at the origin.
pub fn skybox_json(
    width: u32,
    height: u32,
    intensity: f32,
    ev100: f32,
    exposure: f32,
    forward: bevy::math::Vec3,
) -> String {
    format!(
        "{{\n  \"width\": {width},\n  \"height\": {height},\n  \"projection\": \"perspective\",\n  \
         \"camera_position\": [0, 0, 0],\n  \"forward\": [{}, {}, {}],\n  \"up\": [0, 1, 0],\n  \
         \"fov_y_degrees\": {SKYBOX_FOV_Y_DEG},\n  \"skybox\": \"specular\",\n  \
         \"intensity\": {intensity},\n  \"ev100\": {ev100},\n  \"exposure\": {exposure}\n}}\n",
        forward.x, forward.y, forward.z
    )
}
