//! The sun the README adds back (issue 36, `common/sun_lines.rs`), in Bevy: the park map baked
//! with `--sun keep` and `--sun extract`, each rendered by the client under the README's loading
//! code's `EnvironmentMapLight` intensity (998.0957) and the camera's default `Exposure` (EV100
//! 9.7: the loading code's camera sets none), the extracted bake with the README's sun lines read
//! by the client's strict reader of their Rust (clients/bevy/src/sun_lines.rs, compiled here too
//! as `client_sun_lines`) and spawned as the `DirectionalLight` they describe. Included by
//! `#[path]` from tests/bevy_render.rs.

use std::collections::HashMap;
use std::path::Path;

use serde_json::Value as Json;

use crate::client_sun_lines::read_readme;
use crate::scene::Geometry;
use crate::{client, common, run_client, sun_lines, Bake, HEIGHT, WIDTH};

/// The diffuse sphere lit by the extracted bake and the README's sun lines, relative RMSE: 0.043
/// measured against the keep bake's and against exact E / pi alike (the keep bake is 0.0026 off
/// exact), nearly all of it Bevy's Burley diffuse for direct lights (`Fd_Burley`, f90 = 2.2 at
/// this sun and roughness 1: up to 1.13 times Lambert where the sun is), against the Lambertian
/// E / pi of the maps. About twice each (docs/src/guides/baking/bevy.md, "The sun's lines"); the
/// mistakes measure 0.77 and more.
const SUN_BOUND: sun_lines::SunBound = sun_lines::SunBound { keep: 0.09, exact: 0.09 };

/// The `EnvironmentMapLight` intensity of the README's loading code (`intensity: 998.0957,`): the
/// sun's lines multiply the illuminance by it, so the client renders the sun test's bakes at it.
fn readme_intensity(readme: &Path) -> String {
    let text = std::fs::read_to_string(readme).expect("the bake's README.txt");
    let loading = text.split("\nThe sun:\n").next().unwrap_or_default();
    let line = loading.lines().find(|l| l.trim_start().starts_with("intensity:")).expect("an intensity line");
    let value = line.trim().trim_start_matches("intensity:").trim().trim_end_matches(',');
    assert!(value.parse::<f32>().is_ok_and(|v| v > 0.0), "{}: no intensity in {line:?}", readme.display());
    value.to_string()
}

/// The two cube maps of the park bake in `dir`.
fn park_files(dir: &Path) -> Bake {
    Bake { diffuse: dir.join("park_diffuse_rgb9e5_zstd.ktx2"), specular: dir.join("park_specular_rgb9e5_zstd.ktx2") }
}

/// Bevy renders the README's sun lines (read by the client's reader, spawned in the scene) with
/// the extracted bake as the `--sun keep` bake renders the sun held in the map: the diffuse sphere
/// within [`SUN_BOUND`] of it and of exact E / pi, each mistake (no sun lines, the intensity times
/// pi, the direction negated) beyond; the metal of roughness 0.5 reported.
#[test]
fn bevy_adds_the_readmes_sun_as_the_map_held_it() {
    let Some(client) = client() else { return };
    let sandbox = common::Sandbox::new();
    let bakes = sun_lines::bake_park(&sandbox, "bevy");
    let intensity = readme_intensity(&bakes.extract.join("README.txt"));
    assert_eq!(intensity, readme_intensity(&bakes.keep.join("README.txt")), "the two bakes' intensity");

    let mut frames = HashMap::new();
    let mut geometry = None;
    for (name, dir, readme) in bakes.all_renders() {
        let (w, h) = (WIDTH.to_string(), HEIGHT.to_string());
        let mut extra = vec!["--width", &w, "--height", &h, "--default-exposure"];
        if let Some(readme) = readme {
            extra.extend(["--sun", readme.to_str().expect("UTF-8")]);
        }
        let (frame, json) = run_client(&client, &sandbox, &park_files(dir), name, &intensity, &extra);
        let g = Geometry::read(&json);
        // The frame in the map's units: the README's intensity times Bevy's default exposure.
        let scale = g.intensity * g.exposure;
        assert!((scale - 1.0).abs() < 1e-5, "{name}: intensity {} x exposure {} = {scale}", g.intensity, g.exposure);
        let json: Json = serde_json::from_slice(&common::read_file(&json)).expect("the geometry's JSON");
        assert_spawned(name, &json["sun"], readme);
        frames.insert(name, frame);
        geometry = Some(g);
    }
    let g = geometry.expect("renders");
    let frame = |name: &str| frames[name].clone();
    sun_lines::assert_frames_sun("Bevy", &sandbox, &g, &bakes, frame, SUN_BOUND);
}

/// The light the client reports spawning (`"sun"` of its geometry file) is the one the README's
/// lines describe, as read here by the same reader (none without a README).
fn assert_spawned(name: &str, reported: &Json, readme: Option<&Path>) {
    let Some(readme) = readme else {
        assert!(reported.is_null(), "{name}: a sun was spawned without sun lines: {reported}");
        return;
    };
    let lights = read_readme(&std::fs::read_to_string(readme).expect("the README")).expect("the README's sun lines");
    let spawned = reported.as_array().unwrap_or_else(|| panic!("{name}: no sun spawned: {reported}"));
    assert_eq!(spawned.len(), lights.len(), "{name}: {reported}");
    for (s, l) in spawned.iter().zip(&lights) {
        let illuminance = s["illuminance"].as_f64().expect("illuminance") as f32;
        let color: Vec<f32> =
            s["color"].as_array().expect("color").iter().filter_map(|c| c.as_f64()).map(|c| c as f32).collect();
        assert_eq!(Some(illuminance), l.illuminance, "{name}: {s}");
        assert_eq!(l.color.map(Vec::from), Some(color), "{name}: {s}");
        assert_eq!(s["shadow_maps_enabled"].as_bool(), Some(true), "{name}: {s}");
        let forward: Vec<f64> = s["forward"].as_array().expect("forward").iter().filter_map(Json::as_f64).collect();
        let f = glam::DVec3::from_slice(&forward);
        let wanted = glam::DVec3::from_array(l.forward.map(f64::from)).normalize();
        assert!((f - wanted).length() < 1e-5, "{name}: the light shines along {f}, the lines say {wanted}");
        eprintln!("{name}: spawned {s}");
    }
}
