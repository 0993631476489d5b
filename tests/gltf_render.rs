//! The glTF bake, checked by the Khronos validator and rendered for real (issue 36): `hdrflow
//! bake MAP --for gltf --sun keep` writes a glTF 2.0 asset whose scene uses an
//! `EXT_lights_image_based` light (`formats::gltf_ibl`), and Babylon.js (npm `@babylonjs/core`
//! 9.37.1 with `@babylonjs/loaders` 9.28.0, `clients/babylon-web`, WebGL2 in headless Chromium
//! on SwiftShader) loads it with its glTF loader, by the README's own lines, and renders the six
//! spheres of tests/babylon_render.rs with the environment the loader set.
//!
//! - Valid: the Khronos glTF validator (npm `gltf-validator`, `clients/babylon-web/validate-gltf.cjs`)
//!   reports no error on the asset and its images (the extension is unknown to it: an
//!   `UNSUPPORTED_EXTENSION` info), and does report one on a copy missing an image.
//! - The spheres against Babylon's formula fed exact values (`babylon_render/reference.rs`, with
//!   the loader's `lodGenerationScale` `(N - 1) / log2(size)`: 0.5), within the bounds of the
//!   `.env`; on the asymmetric test map each classic mistake fails: the map mirrored, faces +Z
//!   and -Z swapped, a roughness list that maps the levels evenly to 0..1, the coefficients of
//!   `E / pi` instead of `E` (the loader divides by pi itself), the SH in hdrflow's axes
//!   instead of Babylon's, and the faces written as plain 8-bit colour (no RGBD).
//! - Orientation and handedness, as for the `.env`: the marker map through the README's
//!   `createDefaultSkybox` (the light's level 0) shows each marker where a 360-degree viewer does.
//! - The README's lines are lines of the page; a folder holding another glTF asset is refused.
//!
//! Needs Chromium, Node and the client's npm packages (`scripts/babylon-web.sh install`); without
//! them the tests skip visibly, and fail under `HDRFLOW_REQUIRE_BABYLON=1`. Run: `cargo test
//! --release --test gltf_render -- --nocapture` (prints the tables).

#[allow(dead_code)]
#[path = "babylon_render/page.rs"]
mod babylon_page;
#[path = "babylon_render/reference.rs"]
mod babylon_reference;
mod common;
#[allow(dead_code)]
#[path = "common/markers.rs"]
mod markers;
#[allow(dead_code)]
#[path = "bevy_render/reference.rs"]
mod reference;
#[allow(dead_code)]
#[path = "bevy_render/scene.rs"]
mod scene;
#[path = "bevy_render/test_map.rs"]
mod test_map;
#[path = "common/web_page.rs"]
mod web_page;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use babylon_page::{app_dir, rel, write_map, REQUIRE, SPHERES};
use babylon_reference::Levels;
use hdrflow::formats::gltf_ibl::EXTENSION;
use serde_json::{json, Value as Json};

/// The pinned loader (clients/babylon-web/package-lock.json): the newest the registry holds.
const LOADERS_VERSION: &str = "9.28.0";
/// The default bake's chain: faces of 256 down to 16.
const LEVELS: usize = 5;

/// `hdrflow bake MAP --for gltf --sun keep --out DIR` plus `extra`; the .gltf's path.
fn bake(sandbox: &common::Sandbox, map: &Path, dir: &str, extra: &[&str]) -> PathBuf {
    let out = web_page::bake(sandbox, map, "gltf", dir, extra);
    out.join(format!("{}.gltf", map.file_stem().and_then(|s| s.to_str()).expect("a file name")))
}

/// A copy of the asset `gltf` in the sandbox's `dir`, its document passed through `doc` and each
/// PNG through `png`; the copy's .gltf.
fn edited(
    sandbox: &common::Sandbox,
    gltf: &Path,
    dir: &str,
    doc: impl Fn(&mut Json),
    png: impl Fn(&[u8]) -> Vec<u8>,
) -> PathBuf {
    let to = sandbox.join(dir);
    std::fs::create_dir_all(&to).expect("the copy's folder");
    for entry in std::fs::read_dir(gltf.parent().expect("a folder")).expect("the bake").flatten() {
        if entry.path().extension().is_some_and(|e| e == "png") {
            std::fs::write(to.join(entry.file_name()), png(&common::read_file(&entry.path()))).expect("a face");
        }
    }
    let mut d: Json = serde_json::from_slice(&common::read_file(gltf)).expect("the .gltf is JSON");
    doc(&mut d);
    let out = to.join(gltf.file_name().expect("a file name"));
    std::fs::write(&out, serde_json::to_vec_pretty(&d).expect("JSON")).expect("the copy's .gltf");
    out
}

/// The light of a document.
fn light(doc: &mut Json) -> &mut Json {
    &mut doc["extensions"][EXTENSION]["lights"][0]
}

/// A face as an 8-bit colour PNG with no RGBD: the linear value clamped to 1, gamma 2.2, RGB.
fn without_rgbd(png: &[u8]) -> Vec<u8> {
    let img = image::load_from_memory(png).expect("a PNG face").to_rgba8();
    let rgb = image::RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let p = img.get_pixel(x, y).0;
        let v = hdrflow::formats::rgbd::from_rgbd(p);
        image::Rgb(v.map(|c| (c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8))
    });
    let mut out = Vec::new();
    rgb.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).expect("PNG");
    out
}

/// The Khronos validator's report on `gltf` (`clients/babylon-web/validate-gltf.cjs`), or
/// `None` after a visible skip without Node or the npm package.
fn validate(gltf: &Path) -> Option<Json> {
    let script = app_dir().join("validate-gltf.cjs");
    if !app_dir().join("node_modules/gltf-validator/index.js").is_file() {
        common::skip(REQUIRE, "no gltf-validator: scripts/babylon-web.sh install");
        return None;
    }
    if !Command::new("sh").args(["-c", "command -v node"]).output().is_ok_and(|o| o.status.success()) {
        common::skip(REQUIRE, "no node (Node.js)");
        return None;
    }
    let mut cmd = Command::new("node");
    cmd.arg(&script).arg(gltf);
    let out = common::run_command(cmd, Duration::from_secs(300));
    assert_eq!(out.code, Some(0), "{}", out.describe());
    Some(serde_json::from_str(&out.stdout).unwrap_or_else(|e| panic!("the validator's report: {e}\n{}", out.stdout)))
}

/// The report's counts, and its messages as `CODE (severity): pointer` lines.
fn summary(report: &Json) -> (u64, String) {
    let issues = &report["issues"];
    let lines: Vec<String> = issues["messages"]
        .as_array()
        .map(|m| {
            m.iter()
                .map(|m| format!("  {} (severity {}): {} {}", m["code"], m["severity"], m["pointer"], m["message"]))
                .collect()
        })
        .unwrap_or_default();
    let text = format!(
        "errors {}, warnings {}, infos {}, hints {}\n{}",
        issues["numErrors"],
        issues["numWarnings"],
        issues["numInfos"],
        issues["numHints"],
        lines.join("\n")
    );
    (issues["numErrors"].as_u64().expect("numErrors"), text)
}

#[test]
fn the_gltf_asset_is_valid_for_the_khronos_validator() {
    let sandbox = common::Sandbox::new();
    let map = write_map(&sandbox, "test.pfm", &test_map::test_map());
    let good = bake(&sandbox, &map, "good", &["--quality", "draft"]);
    let Some(report) = validate(&good) else { return };
    let (errors, text) = summary(&report);
    eprintln!("gltf-validator {} on {}: {text}", report["validatorVersion"], good.display());
    assert_eq!(errors, 0, "{text}");
    assert!(text.contains("UNSUPPORTED_EXTENSION"), "the validator does not know {EXTENSION}: {text}");
    // The validator does read the images: one missing is an error.
    let broken = edited(&sandbox, &good, "broken", |_| {}, <[u8]>::to_vec);
    std::fs::remove_file(broken.with_file_name("test_specular_1_nz.png")).expect("an image to remove");
    let (errors, text) = summary(&validate(&broken).expect("validated once"));
    assert!(errors > 0, "a missing image passed: {text}");
}

#[test]
fn gltf_shows_the_test_map_and_each_mistake_fails() {
    let Some(browser) = babylon_page::browser(&["@babylonjs/loaders/glTF/index.js"]) else { return };
    let sandbox = common::Sandbox::new();
    let map = test_map::test_map();
    let plain = write_map(&sandbox, "test.pfm", &map);
    let good = bake(&sandbox, &plain, "good", &[]);
    let mirrored = write_map(&sandbox, "test_mirrored.pfm", &markers::mirror_x(&map));
    let mirrored = bake(&sandbox, &mirrored, "mirrored", &[]);
    // The README's "evenly map to roughness values from 0 to 1", where Babylon reads 2^(l / 0.5) / 256.
    let even = bake(&sandbox, &plain, "even", &["--set", "spec.roughness_list=[0.0, 0.25, 0.5, 0.75, 1.0]"]);
    let swapped = edited(
        &sandbox,
        &good,
        "swapped",
        |d| {
            for level in light(d)["specularImages"].as_array_mut().expect("the levels") {
                level.as_array_mut().expect("six faces").swap(4, 5);
            }
        },
        <[u8]>::to_vec,
    );
    let over_pi = edited(
        &sandbox,
        &good,
        "over_pi",
        |d| {
            let c = &mut light(d)["irradianceCoefficients"];
            let scaled: Vec<Vec<f64>> = serde_json::from_value::<Vec<Vec<f64>>>(c.take())
                .expect("9 RGB triples")
                .into_iter()
                .map(|rgb| rgb.into_iter().map(|v| v / std::f64::consts::PI).collect())
                .collect();
            *c = json!(scaled);
        },
        <[u8]>::to_vec,
    );
    let no_rgbd = edited(&sandbox, &good, "no_rgbd", |_| {}, without_rgbd);
    // The SH in hdrflow's axes (z backwards for Babylon) instead of Babylon's.
    let world = bake(&sandbox, &plain, "world", &["--set", "sh.frame=World"]);

    let bakes = [
        ("good", &good),
        ("mirrored", &mirrored),
        ("even", &even),
        ("swapped", &swapped),
        ("over_pi", &over_pi),
        ("no_rgbd", &no_rgbd),
        ("world", &world),
    ];
    let mut renders: Vec<Json> =
        bakes.iter().map(|(name, g)| json!({ "name": name, "kind": "spheres", "gltf": rel(&sandbox, g) })).collect();
    // The README's code without its gammaSpace line: the correct asset, as the loader leaves it.
    renders
        .push(json!({ "name": "loader_gamma", "kind": "spheres", "gltf": rel(&sandbox, &good), "loader_gamma": true }));
    let job = json!({ "renders": renders });
    let page = babylon_page::run_page(browser, &sandbox, "gltf-render", "test-map", &job, 0.5);
    assert_eq!(page.report["loaders"], LOADERS_VERSION, "the pinned loader (clients/babylon-web/package-lock.json)");
    let loaded = &page.render_report("good")["loaded"];
    assert_eq!((&loaded["class"], &loaded["width"]), (&json!("CubeTexture"), &json!(256)), "{loaded}");
    assert_eq!(loaded["gammaSpace"], false, "{loaded}");
    let as_loaded = &page.render_report("loader_gamma")["loaded"];
    assert_eq!(as_loaded["gammaSpace"], true, "Babylon's loader now makes a linear texture: {as_loaded}");
    let mistakes: [(&str, &[&str]); 7] = [
        ("mirrored", &SPHERES[..]),
        // Roughness 1 and the diffuse sphere read only the SH (Babylon mixes the radiance with
        // the irradiance by alphaG).
        ("swapped", &SPHERES[..4]),
        ("even", &SPHERES[1..4]),
        ("over_pi", &SPHERES[1..]),
        ("no_rgbd", &SPHERES[..4]),
        ("world", &SPHERES[2..]),
        ("loader_gamma", &SPHERES[..4]),
    ];
    babylon_page::assert_spheres(&page, map, Levels::gltf(256, LEVELS), "test map (gltf)", &mistakes);
}

/// The marker map through the skybox of the README's code (`createDefaultSkybox`, the light's
/// level 0), as for the `.env`: each marker where a 360-degree viewer puts it; a mirrored map fails.
#[test]
fn gltf_shows_the_marker_map_as_a_360_viewer_does() {
    let Some(browser) = babylon_page::browser(&["@babylonjs/loaders/glTF/index.js"]) else { return };
    babylon_page::assert_markers(browser, "gltf", "gltf-render", 0.5, bake);
}

/// `hdrflow bake MAP --for gltf --sun keep --quality draft --out OUT` in `sandbox`.
fn bake_draft(sandbox: &common::Sandbox, map: &Path, out: &Path) -> common::Output {
    babylon_page::bake_draft(sandbox, "gltf", map, out)
}

/// The README's glTF code is the render page's (`clients/babylon-web/render.js` loads the asset
/// with it): every code line but the one naming the file is a line of that page, and that one
/// names the .gltf the bake wrote, with 4 levels of 6 faces beside it (128 down to 16); a texel
/// beyond RGBD's 255 is counted in a warning.
#[test]
fn the_gltf_readme_code_is_the_render_pages_code() {
    let sandbox = common::Sandbox::new();
    let out = babylon_page::assert_readme_code_is_the_pages(&sandbox, "gltf", 5);
    let doc: Json = serde_json::from_slice(&common::read_file(&out.join("bright.gltf"))).expect("JSON");
    let light = &doc["extensions"][EXTENSION]["lights"][0];
    assert_eq!(light["specularImageSize"], 128);
    assert_eq!(light["specularImages"].as_array().map(Vec::len), Some(4));
    for image in doc["images"].as_array().expect("the images") {
        let uri = image["uri"].as_str().expect("a uri");
        assert!(out.join(uri).is_file(), "{uri}: not beside the .gltf");
    }
}

/// A folder holding another glTF asset is refused before anything runs; an earlier glTF bake
/// of the same map is baked over.
#[test]
fn a_folder_holding_another_gltf_asset_is_refused() {
    let sandbox = common::Sandbox::new();
    let map = write_map(&sandbox, "sky.pfm", &test_map::test_map());
    let out = sandbox.join("assets");
    common::write_file(&out.join("robot.gltf"), "{\"asset\": {\"version\": \"2.0\"}}");
    let o = bake_draft(&sandbox, &map, &out);
    o.assert_code(2).assert_stderr_contains("holds a glTF asset, robot.gltf, not this bake's");
    assert!(!out.join("README.txt").exists() && !out.join("sky.gltf").exists(), "something was written");
    // The same map's own asset, not written by a bake: refused too.
    let own = sandbox.join("own");
    common::write_file(&own.join("sky.gltf"), "{}");
    bake_draft(&sandbox, &map, &own).assert_code(2).assert_stderr_contains("sky.gltf, that no gltf bake wrote");
    // An earlier glTF bake of the map: baked over.
    let again = sandbox.join("again");
    bake_draft(&sandbox, &map, &again).assert_success();
    bake_draft(&sandbox, &map, &again).assert_success();
}
