//! What the Babylon.js render tests share (tests/babylon_render.rs: a `.env`; tests/gltf_render.rs:
//! a glTF asset's `EXT_lights_image_based` light): the client (`clients/babylon-web`), its pinned
//! packages, the run of its page, the sphere scene's camera and bounds, the shader pieces the
//! reference models, the table of errors, the sphere and README checks, the orientation views of
//! the marker map, and the RGBD-without-gamma mistake. Included by `#[path]` as `babylon_page`,
//! beside `common`, `web_page`, `markers`, `reference` (Bevy's), `scene` and `babylon_reference`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use glam::DVec3;
use hdrflow::values::Image;
use serde_json::{json, Value as Json};

use crate::babylon_reference::{sh_polynomial, sphere_reference, Levels, SphereReference};
use crate::reference::Map;
use crate::scene::Geometry;
pub use crate::web_page::{rel, write_map};
use crate::{common, markers, web_page};

pub const REQUIRE: &str = "HDRFLOW_REQUIRE_BABYLON";
/// The pinned engine (clients/babylon-web/package-lock.json).
pub const PACKAGE_VERSION: &str = "9.37.1";
/// The orthographic camera of the sphere renders (clients/web-common/scene.js: on +Z at CAMERA_Z).
pub const CAMERA: DVec3 = DVec3::new(0.0, 0.0, 10.0);
/// Relative RMSE bounds per sphere (mirror, metals 0.25, 0.5, 0.75, 1, diffuse) on the test map:
/// about twice what the correct bakes measure (the `.env`: docs/src/guides/baking/babylon.md; the
/// glTF light, whose chain stops at 16: docs/src/guides/baking/gltf.md), at least 0.002.
pub const TEST_MAP_BOUNDS: [f64; 6] = [0.03, 0.01, 0.005, 0.003, 0.002, 0.002];
/// SwiftShader is a CPU renderer on a shared machine: a minute is possible, ten are a hang.
pub const BROWSER_TIMEOUT: Duration = Duration::from_secs(600);
/// The orientation views: 256 x 256, 90 degrees (`markers::SkyCamera`).
const SKY_SIZE: usize = 256;
const SKY_FOV: f64 = 90.0;
/// How far (pixels) a marker may land from where a 360-degree viewer puts it.
const MARKER_TOLERANCE: f64 = 2.0;

pub fn app_dir() -> PathBuf {
    Path::new(common::MANIFEST_DIR).join("clients/babylon-web")
}

/// Chromium, or `None` after a visible skip when it or one of the npm packages' `files` (beside
/// Babylon's core) is missing.
pub fn browser(files: &[&str]) -> Option<&'static str> {
    let core = ["@babylonjs/core/index.js", "@babylonjs/core/Misc/environmentTextureTools.js"];
    let all: Vec<&str> = core.iter().chain(files).copied().collect();
    web_page::browser(REQUIRE, &app_dir(), &all, "scripts/babylon-web.sh install")
}

/// A PNG face rewritten as if the RGBD encoder had left out the gamma (RGB stored linearly).
pub fn without_gamma(png: &[u8]) -> Vec<u8> {
    let mut img = image::load_from_memory(png).expect("a PNG face").to_rgba8();
    for p in img.pixels_mut() {
        for c in 0..3 {
            p.0[c] = ((p.0[c] as f64 / 255.0).powf(2.2) * 255.0).round() as u8;
        }
    }
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).expect("PNG");
    out
}

/// The pieces of Babylon's PBR shader `babylon_render/reference.rs` models, in the GLSL it
/// compiled (an upgrade that changes them must revisit the reference).
pub const SPHERE_SHADER: [&str; 4] = [
    "reflectionLOD=reflectionLOD*vReflectionMicrosurfaceInfos.y+vReflectionMicrosurfaceInfos.z",
    "float lod=log2(microsurfaceAverageSlopeTexels)",
    "mix(environmentRadiance.rgb,environmentIrradiance,alphaG)",
    "return 1.0+specularEnvironmentR0*(1.0/environmentBrdf.y-1.0)",
];

/// Chromium's virtual-time budget for a Babylon page (`web_page::run_with_budget`): Babylon's
/// `CreateEnvTextureAsync` readbacks poll with timers, and on a loaded machine one page spent 23
/// hours of virtual time in 33 s (2026-12-07; the day of `web_page::run` then ran out before the
/// page's end). About 23 days, near the flag's limit (a 32-bit count of milliseconds).
const VIRTUAL_TIME_BUDGET_MS: u64 = 2_000_000_000;

/// The page run on `job` (results kept in `target/tmp/KEEP/LABEL`): the pinned engine, each
/// render stable and its texture read with `lod_scale` as lodGenerationScale.
pub fn run_page(
    browser: &str,
    sandbox: &common::Sandbox,
    keep: &str,
    label: &str,
    job: &Json,
    lod_scale: f64,
) -> web_page::Page {
    let page = web_page::run_with_budget(
        browser,
        &app_dir(),
        sandbox,
        job,
        &format!("{keep}/{label}"),
        BROWSER_TIMEOUT,
        VIRTUAL_TIME_BUDGET_MS,
    );
    assert_eq!(page.report["package"], PACKAGE_VERSION, "the pinned engine (clients/babylon-web/package-lock.json)");
    for r in page.report["renders"].as_array().expect("the renders") {
        assert_eq!(r["stable"], true, "{}: the second frame differs from the first", r["name"]);
        assert_eq!(r["loaded"]["lodGenerationScale"], lod_scale, "{r}");
    }
    page
}

/// Relative RMSE per sphere against the `engine` references (printed with the exact ones).
pub fn errors(label: &str, frame: &Image, geometry: &Geometry, refs: &[SphereReference]) -> Vec<f64> {
    crate::reference::engine_errors(label, "Babylon's", frame, &geometry.spheres, refs)
}

/// The six spheres, in the scene's order.
pub const SPHERES: [&str; 6] = ["mirror", "metal_0.25", "metal_0.5", "metal_0.75", "metal_1", "diffuse"];

/// The page's sphere renders of the test `map` lit by a chain `levels`: render "good" within
/// [`TEST_MAP_BOUNDS`] of Babylon's formula on every sphere, and each mistake's render (name, the
/// spheres it must fail) failing on those; the shader pieces the reference models present.
pub fn assert_spheres(page: &web_page::Page, map: Image, levels: Levels, label: &str, mistakes: &[(&str, &[&str])]) {
    let shaders = std::fs::read_to_string(page.results.join("shaders.txt")).expect("the recorded shader");
    for piece in SPHERE_SHADER {
        assert!(shaders.contains(piece), "the recorded shader has no {piece:?}");
    }
    let geometry = Geometry::read(&page.results.join("scene.json"));
    let map = Map::new(map);
    let poly = sh_polynomial(&map);
    let refs: Vec<SphereReference> = (0..geometry.spheres.len())
        .map(|k| sphere_reference(&map, &poly, &geometry.spheres[k], &geometry.pixels(k, 0.9, 2), CAMERA, levels))
        .collect();
    let (w, h) = (geometry.width, geometry.height);
    let good_errors = errors(label, &page.frame("good", w, h), &geometry, &refs);
    let good_failing = geometry.failing(&good_errors, &TEST_MAP_BOUNDS);
    let mut missed = Vec::new();
    for (name, must_fail) in mistakes {
        let errs = errors(name, &page.frame(name, w, h), &geometry, &refs);
        missed.extend(geometry.missed(name, &errs, &TEST_MAP_BOUNDS, must_fail));
    }
    assert_eq!(good_failing, Vec::<String>::new(), "the correct bake must match");
    assert!(missed.is_empty(), "mistakes the comparison did not catch:\n{}", missed.join("\n"));
}

/// `hdrflow bake MAP --for ENGINE --sun keep --quality draft --out OUT` in `sandbox`.
pub fn bake_draft(sandbox: &common::Sandbox, engine: &str, map: &Path, out: &Path) -> common::Output {
    let cache = sandbox.cache();
    let (map, out, cache) =
        (map.to_str().expect("UTF-8"), out.to_str().expect("UTF-8"), cache.to_str().expect("UTF-8"));
    let args =
        ["bake", map, "--for", engine, "--sun", "keep", "--quality", "draft", "--out", out, "--cache-dir", cache];
    common::run_hdrflow(args)
}

/// The README's Babylon code is the render page's (`clients/babylon-web/render.js` loads the bake
/// with it): a draft bake for `engine` of a map with one texel beyond RGBD's 255 (counted in a
/// warning) into the sandbox's `bright/`, whose every code line but the one naming the file is a
/// line of the page (`lines` of them), and that one (`const ...Url = '...'`) names a file the
/// bake wrote. The bake's folder.
pub fn assert_readme_code_is_the_pages(sandbox: &common::Sandbox, engine: &str, lines: usize) -> PathBuf {
    let mut bright = Image::new(64, 32, 3);
    bright.data.iter_mut().for_each(|v| *v = 0.5);
    bright.data[3 * (16 * 64 + 20)..3 * (16 * 64 + 21)].copy_from_slice(&[1000.0, 900.0, 800.0]);
    let map = write_map(sandbox, "bright.pfm", &bright);
    let out = sandbox.join("bright");
    let o = bake_draft(sandbox, engine, &map, &out);
    o.assert_success();
    let text = format!("{}{}", o.stdout, o.stderr);
    assert!(text.contains("beyond RGBD's range (255) clamped"), "{text}");
    let readme = std::fs::read_to_string(out.join("README.txt")).expect("the bake's README.txt");
    let page = std::fs::read_to_string(app_dir().join("render.js")).expect("the page");
    let page_lines: Vec<&str> = page.lines().map(str::trim).collect();
    let code = &readme[readme.find("// Babylon.js (@babylonjs/core").expect("the loading code")..];
    let mut checked = 0;
    for line in code.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")) {
        if let Some((_, file)) = line.strip_prefix("const ").and_then(|l| l.split_once("Url = '")) {
            let file = file.trim_end_matches("';");
            assert!(out.join(file).is_file(), "{line}: no such file written");
        } else {
            assert!(page_lines.contains(&line), "not a line of clients/babylon-web/render.js: {line}");
            checked += 1;
        }
    }
    assert_eq!(checked, lines, "{code}");
    out
}

/// The marker map through `scene.createDefaultSkybox` (the texture's level 0) seen by a perspective
/// camera at the origin: each marker where a 360-degree viewer facing the map's centre puts it,
/// looking along -Z (hdrflow's axes: +Z in Babylon's left-handed world), and, baked with `--yaw
/// -90`, along +X; a mirrored map fails. `bake(sandbox, map, dir, extra)` makes each bake,
/// loaded as the job's `key` ("env" or "gltf"), read with `lod_scale`; results kept in `keep`.
pub fn assert_markers(
    browser: &str,
    key: &str,
    keep: &str,
    lod_scale: f64,
    bake: fn(&common::Sandbox, &Path, &str, &[&str]) -> PathBuf,
) {
    let sandbox = common::Sandbox::new();
    let plain = write_map(&sandbox, "markers.pfm", &markers::orientation_map());
    let mirrored = write_map(&sandbox, "mirrored.pfm", &markers::mirror_x(&markers::orientation_map()));
    let good = bake(&sandbox, &plain, "good", &[]);
    let turned = bake(&sandbox, &plain, "yaw", &["--yaw", "-90"]);
    let bad = bake(&sandbox, &mirrored, "mirrored", &[]);
    let views = [
        ("front", &good, DVec3::NEG_Z, 0.0, false),
        // `--yaw -90` turns the map's centre to +X.
        ("yaw", &turned, DVec3::X, -90.0, false),
        ("yaw_front", &turned, DVec3::NEG_Z, 0.0, true),
        ("mirrored", &bad, DVec3::NEG_Z, 0.0, true),
    ];
    let renders: Vec<Json> = views
        .iter()
        .map(|(name, file, forward, _, _)| {
            json!({ "name": name, "kind": "sky", key: rel(&sandbox, file), "forward": forward.to_array(),
                    "fov_deg": SKY_FOV, "size": SKY_SIZE })
        })
        .collect();
    let page = run_page(browser, &sandbox, keep, "markers", &json!({ "renders": renders }), lod_scale);
    let seen: Vec<markers::View> = views
        .iter()
        .map(|(name, _, forward, yaw, mistake)| markers::View {
            name,
            img: page.frame(name, SKY_SIZE, SKY_SIZE),
            forward: *forward,
            yaw: *yaw,
            mistake: *mistake,
        })
        .collect();
    markers::assert_views(&seen, "mirrored", MARKER_TOLERANCE);
}

/// A sphere frame as an 8-bit sRGB PNG (RGB clamped to [0, 1], alpha kept) for the book's pictures.
pub fn save_picture(frame: &Image, path: &Path) {
    let srgb = |v: f32| hdrflow::formats::srgb8::linear_to_srgb8(v as f64);
    let img = image::RgbaImage::from_fn(frame.width as u32, frame.height as u32, |x, y| {
        let p = &frame.data[(y as usize * frame.width + x as usize) * 4..][..4];
        image::Rgba([srgb(p[0]), srgb(p[1]), srgb(p[2]), (p[3].clamp(0.0, 1.0) * 255.0).round() as u8])
    });
    img.save(path).expect("the picture");
}
