//! PlayCanvas, rendered for real (issue 36): `hdrflow bake MAP --for playcanvas --sun keep` writes
//! the RGBP `envAtlas` and skybox PNGs, and PlayCanvas (npm `playcanvas` 2.23.3,
//! `clients/playcanvas-web`, WebGL2 in headless Chromium on SwiftShader) renders six spheres with
//! them, loaded by the README's own lines. Each frame is read back as 32-bit floats, linear and
//! unclamped (`clients/playcanvas-web/render.js` says how).
//!
//! - The spheres (mirror, specular 0.25 to 1, a diffuse one) against PlayCanvas' formula fed exact
//!   values (`playcanvas_render/reference.rs`): relative RMSE over their inner pixels, asserted;
//!   against the exact GGX integral, reported. On the asymmetric test map of tests/bevy_render.rs
//!   each classic mistake fails: the map mirrored, RGBP written without its half power (atlas and
//!   skybox), the
//!   levels holding alpha = 2k / 11 where PlayCanvas reads roughness, the ambient holding E
//!   instead of E / pi.
//! - Orientation and handedness: a map of coloured markers (`common/markers.rs`) through
//!   `app.scene.skybox` must show each marker where a 360-degree viewer facing the map's centre
//!   does, looking along -Z and, baked with `--yaw -90`, along +X; a mirrored map fails.
//! - The sun's lines (`common/sun_lines.rs`): the park map baked with `--sun extract`, its README's
//!   lines under "The sun:" run by the page as they are, against the `--sun keep` bake and the
//!   map's exact E / pi on the diffuse sphere; no sun lines, the intensity times pi and the
//!   direction negated fail.
//!
//! Needs Chromium and the client's npm package (`scripts/playcanvas-web.sh install`: `npm ci` in
//! clients/playcanvas-web); without them the tests skip visibly, and fail under
//! `HDRFLOW_REQUIRE_PLAYCANVAS=1`. Run: `cargo test --release --test playcanvas_render --
//! --nocapture` (prints the tables).

mod common;
#[path = "common/markers.rs"]
mod markers;
#[path = "playcanvas_render/reference.rs"]
mod playcanvas_reference;
#[allow(dead_code)]
#[path = "bevy_render/reference.rs"]
mod reference;
#[allow(dead_code)]
#[path = "bevy_render/scene.rs"]
mod scene;
#[path = "common/sun_lines.rs"]
mod sun_lines;
#[path = "bevy_render/test_map.rs"]
mod test_map;
#[path = "common/web_page.rs"]
mod web_page;

use std::path::{Path, PathBuf};
use std::time::Duration;

use glam::DVec3;
use hdrflow::formats::playcanvas_atlas;
use hdrflow::formats::rgbp::{from_rgbp, rgbp};
use hdrflow::values::Image;
use playcanvas_reference::{sphere_reference, SphereReference};
use reference::Map;
use scene::Geometry;
use serde_json::{json, Value as Json};
use web_page::{rel, write_map};

const REQUIRE: &str = "HDRFLOW_REQUIRE_PLAYCANVAS";
/// The pinned engine (clients/playcanvas-web/package-lock.json).
const PACKAGE_VERSION: &str = "2.23.3";
/// The orthographic camera of the sphere renders (clients/web-common/scene.js: on +Z at CAMERA_Z).
const CAMERA: DVec3 = DVec3::new(0.0, 0.0, 10.0);
/// Relative RMSE bounds per sphere (mirror, specular 0.25, 0.5, 0.75, 1, diffuse) on the test
/// map: about twice what the correct bake measures (0.0175, 0.0167, 0.0201, 0.0175, 0.0298,
/// 0.0025: docs/src/guides/baking/playcanvas.md).
const TEST_MAP_BOUNDS: [f64; 6] = [0.035, 0.035, 0.04, 0.035, 0.06, 0.005];
/// The diffuse sphere lit by the extracted bake and the README's sun lines
/// (`playcanvas_adds_the_readmes_sun_as_the_map_held_it`), relative RMSE: against the keep bake's,
/// 0.014 measured, what the keep bake's ambient is off exact E / pi (0.014); against exact E / pi,
/// 0.0008 measured (the lines before the light's colour was gamma-encoded: 0.144).
const SUN_BOUND: sun_lines::SunBound = sun_lines::SunBound { keep: 0.03, exact: 0.005 };
/// SwiftShader is a CPU renderer on a shared machine: a minute is possible, ten are a hang.
const BROWSER_TIMEOUT: Duration = Duration::from_secs(600);
/// Chromium's virtual-time budget for a page: 100 hours, since virtual time runs about 50 times
/// faster than the wall clock while PlayCanvas filters its skybox (`web_page::run_with_budget`).
const VIRTUAL_TIME_BUDGET_MS: u64 = 360_000_000;
/// The orientation views: 256 x 256, 90 degrees (`markers::SkyCamera`).
const SKY_SIZE: usize = 256;
const SKY_FOV: f64 = 90.0;
/// How far (pixels) a marker may land from where a 360-degree viewer puts it.
const MARKER_TOLERANCE: f64 = 2.0;
/// The six spheres, in the scene's order.
const SPHERES: [&str; 6] = ["mirror", "metal_0.25", "metal_0.5", "metal_0.75", "metal_1", "diffuse"];
/// The pieces of PlayCanvas' shader the reference models, in the GLSL it compiled (an upgrade
/// that changes them must revisit the reference).
const SPHERE_SHADER: [&str; 4] = [
    "float level = saturate(1.0 - gloss) * 5.0;",
    "return processEnvironment(mix(sharp, mix(roughA, roughB, flevel), min(level, 1.0)));",
    "vec3 color = raw.rgb * (-raw.a * 7.0 + 8.0);",
    "vec2 uv = mapUv(toSphericalUv(dir), vec4(128.0, 256.0 + 128.0, 64.0, 32.0) / atlasSize);",
];

fn app_dir() -> PathBuf {
    Path::new(common::MANIFEST_DIR).join("clients/playcanvas-web")
}

/// Chromium, or `None` after a visible skip when it or the npm package is missing.
fn browser() -> Option<&'static str> {
    web_page::browser(REQUIRE, &app_dir(), &["playcanvas/build/playcanvas.mjs"], "scripts/playcanvas-web.sh install")
}

/// A bake's two files (relative to the sandbox, for the job): the atlas and the skybox.
struct Files {
    atlas: PathBuf,
    sky: PathBuf,
}

/// `hdrflow bake MAP --for playcanvas --sun keep --out DIR` plus `extra`.
fn bake(sandbox: &common::Sandbox, map: &Path, dir: &str, extra: &[&str]) -> Files {
    let out = web_page::bake(sandbox, map, "playcanvas", dir, extra);
    let stem = map.file_stem().and_then(|s| s.to_str()).expect("a file name");
    Files { atlas: out.join(format!("{stem}_envAtlas.png")), sky: out.join(format!("{stem}_skybox.png")) }
}

/// The RGBP PNG at `path` with each texel's decoded value (and its position) passed through
/// `edit`, which returns the RGBA bytes to store, written to `dir/` in the sandbox.
fn edit_png(
    sandbox: &common::Sandbox,
    path: &Path,
    dir: &str,
    edit: &impl Fn(usize, usize, [f32; 3]) -> [u8; 4],
) -> PathBuf {
    let mut img = image::load_from_memory(&common::read_file(path)).expect("an RGBP PNG").to_rgba8();
    for (x, y, p) in img.enumerate_pixels_mut() {
        p.0 = edit(x as usize, y as usize, from_rgbp(p.0));
    }
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).expect("PNG");
    sandbox.write(Path::new(dir).join(path.file_name().expect("a name")), png)
}

/// `files` with the atlas, and with `sky` the skybox too, passed through `edit` (`edit_png`).
fn edited(
    sandbox: &common::Sandbox,
    files: &Files,
    dir: &str,
    sky: bool,
    edit: impl Fn(usize, usize, [f32; 3]) -> [u8; 4],
) -> Files {
    let atlas = edit_png(sandbox, &files.atlas, dir, &edit);
    let sky = if sky { edit_png(sandbox, &files.sky, dir, &edit) } else { files.sky.clone() };
    Files { atlas, sky }
}

/// RGBP as if the encoder had left out the half power: the bytes of `c / (8 - 7 v)`, which
/// PlayCanvas decodes to `c^2`.
fn without_sqrt(c: [f32; 3]) -> [u8; 4] {
    let m = c[0].max(c[1]).max(c[2]).clamp(1.0, 8.0);
    let v = ((1.0 - (m - 1.0) / 7.0) * 255.0).ceil() / 255.0;
    let rgb = c.map(|x| ((x / (8.0 - 7.0 * v)).clamp(0.0, 1.0) * 255.0).round() as u8);
    [rgb[0], rgb[1], rgb[2], (v * 255.0).round() as u8]
}

fn job_entry(sandbox: &common::Sandbox, name: &str, files: &Files) -> Json {
    json!({ "name": name, "kind": "spheres", "atlas": rel(sandbox, &files.atlas), "sky": rel(sandbox, &files.sky) })
}

/// The page run on `job`: the pinned engine, each render stable.
fn run_page(browser: &str, sandbox: &common::Sandbox, label: &str, job: &Json) -> web_page::Page {
    let keep = format!("playcanvas-render/{label}");
    let page =
        web_page::run_with_budget(browser, &app_dir(), sandbox, job, &keep, BROWSER_TIMEOUT, VIRTUAL_TIME_BUDGET_MS);
    assert_eq!(page.report["package"], PACKAGE_VERSION, "the pinned engine (clients/playcanvas-web/package-lock.json)");
    for r in page.report["renders"].as_array().expect("the renders") {
        assert_eq!(r["stable"], true, "{}: the second frame differs from the first", r["name"]);
        assert_eq!(r["loaded"]["width"], 512, "{r}");
    }
    page
}

/// Relative RMSE per sphere against the engine references (printed with the exact ones).
fn errors(label: &str, frame: &Image, geometry: &Geometry, refs: &[SphereReference]) -> Vec<f64> {
    reference::engine_errors(label, "PlayCanvas'", frame, &geometry.spheres, refs)
}

#[test]
fn playcanvas_shows_the_test_map_and_each_mistake_fails() {
    let Some(browser) = browser() else { return };
    let sandbox = common::Sandbox::new();
    let map = test_map::test_map();
    let plain = write_map(&sandbox, "test.pfm", &map);
    let good = bake(&sandbox, &plain, "good", &[]);
    let mirrored = bake(&sandbox, &write_map(&sandbox, "test_mirrored.pfm", &markers::mirror_x(&map)), "mirrored", &[]);
    // The levels holding alpha = 2k / 11 (roughness sqrt(2k / 11)) where PlayCanvas reads roughness 2k / 11.
    let alpha: Vec<String> = std::iter::once(0.0)
        .chain((1..7).map(|k| playcanvas_atlas::level_roughness(k).sqrt()))
        .map(|r| format!("{r:?}"))
        .collect();
    let alpha = bake(&sandbox, &plain, "alpha", &["--set", &format!("spec.roughness_list=[{}]", alpha.join(", "))]);
    let no_sqrt = edited(&sandbox, &good, "no_sqrt", true, |_, _, c| without_sqrt(c));
    let a = playcanvas_atlas::AMBIENT;
    let times_pi = edited(&sandbox, &good, "times_pi", false, |x, y, c| {
        let inside = (a.x..a.x + a.w).contains(&x) && (a.y..a.y + a.h).contains(&y);
        rgbp(if inside { c.map(|v| v * std::f32::consts::PI) } else { c }).0
    });
    let bakes =
        [("good", &good), ("mirrored", &mirrored), ("alpha", &alpha), ("no_sqrt", &no_sqrt), ("times_pi", &times_pi)];
    let mut renders: Vec<Json> = bakes.iter().map(|(name, f)| job_entry(&sandbox, name, f)).collect();
    // PlayCanvas' own prefiltering of the same panorama (EnvLighting.generateAtlas of the skybox
    // PNG), for the table of which atlas is closer: reported, not asserted.
    let mut own = job_entry(&sandbox, "own", &good);
    own["own"] = json!(true);
    renders.push(own);
    let page = run_page(browser, &sandbox, "test-map", &json!({ "renders": renders }));
    // generateSkyboxCubemap's default size: a quarter of the panorama's width.
    let loaded = &page.render_report("good")["loaded"];
    assert_eq!(loaded["skybox"], 128, "{loaded}");
    let shaders = std::fs::read_to_string(page.results.join("shaders.txt")).expect("the recorded shader");
    for piece in SPHERE_SHADER {
        assert!(shaders.contains(piece), "the recorded shader has no {piece:?}");
    }
    let geometry = Geometry::read(&page.results.join("scene.json"));
    let map = Map::new(map);
    let refs: Vec<SphereReference> = (0..geometry.spheres.len())
        .map(|k| sphere_reference(&map, &geometry.spheres[k], &geometry.pixels(k, 0.9, 2), CAMERA))
        .collect();
    let (w, h) = (geometry.width, geometry.height);
    let good_errors = errors("test map", &page.frame("good", w, h), &geometry, &refs);
    let good_failing = geometry.failing(&good_errors, &TEST_MAP_BOUNDS);
    let mistakes: [(&str, &[&str]); 4] = [
        ("mirrored", &SPHERES[..]),
        // Roughness 1 reads level 5 alone, whose blur the 14 x 6 texels of its rect hide.
        ("alpha", &SPHERES[1..4]),
        ("no_sqrt", &SPHERES[..]),
        ("times_pi", &SPHERES[5..]),
    ];
    errors("PlayCanvas' own atlas (EnvLighting.generateAtlas)", &page.frame("own", w, h), &geometry, &refs);
    let mut missed = Vec::new();
    for (name, must_fail) in mistakes {
        let errs = errors(name, &page.frame(name, w, h), &geometry, &refs);
        missed.extend(geometry.missed(name, &errs, &TEST_MAP_BOUNDS, must_fail));
    }
    assert_eq!(good_failing, Vec::<String>::new(), "the correct bake must match");
    assert!(missed.is_empty(), "mistakes the comparison did not catch:\n{}", missed.join("\n"));
}

#[test]
fn playcanvas_shows_the_marker_map_as_a_360_viewer_does() {
    let Some(browser) = browser() else { return };
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
    // One page per view: each builds its skybox cube (1024 samples per texel on SwiftShader),
    // and the page's virtual-time budget is per page.
    let seen: Vec<markers::View> = views
        .iter()
        .map(|(name, f, forward, yaw, mistake)| {
            let render = json!({ "name": name, "kind": "sky", "atlas": rel(&sandbox, &f.atlas), "sky": rel(&sandbox, &f.sky),
                                 "forward": forward.to_array(), "fov_deg": SKY_FOV, "size": SKY_SIZE });
            let page = run_page(browser, &sandbox, &format!("markers-{name}"), &json!({ "renders": [render] }));
            markers::View { name, img: page.frame(name, SKY_SIZE, SKY_SIZE), forward: *forward, yaw: *yaw, mistake: *mistake }
        })
        .collect();
    markers::assert_views(&seen, "mirrored", MARKER_TOLERANCE);
}

/// The README's PlayCanvas code is the render page's (`clients/playcanvas-web/render.js` loads the
/// bake with it): a draft bake of a map with one texel beyond RGBP's 64 (counted in a warning),
/// whose every code line but the two naming the files is a line of the page, and those name files
/// the bake wrote.
#[test]
fn the_playcanvas_readme_code_is_the_render_pages_code() {
    let sandbox = common::Sandbox::new();
    let mut bright = Image::new(64, 32, 3);
    bright.data.iter_mut().for_each(|v| *v = 0.5);
    bright.data[3 * (16 * 64 + 20)..3 * (16 * 64 + 21)].copy_from_slice(&[1000.0, 900.0, 800.0]);
    let map = write_map(&sandbox, "bright.pfm", &bright);
    let out = sandbox.join("bright");
    let cache = sandbox.cache();
    let args = [
        "bake",
        map.to_str().expect("UTF-8"),
        "--for",
        "playcanvas",
        "--sun",
        "keep",
        "--quality",
        "draft",
        "--out",
        out.to_str().expect("UTF-8"),
        "--cache-dir",
        cache.to_str().expect("UTF-8"),
    ];
    let o = common::run_hdrflow(args);
    o.assert_success();
    let text = format!("{}{}", o.stdout, o.stderr);
    assert!(text.contains("beyond RGBP's range (64) clamped"), "{text}");
    let readme = std::fs::read_to_string(out.join("README.txt")).expect("the bake's README.txt");
    let page = std::fs::read_to_string(app_dir().join("render.js")).expect("the page");
    let page_lines: Vec<&str> = page.lines().map(str::trim).collect();
    let code = &readme[readme.find("// PlayCanvas (playcanvas 2)").expect("the loading code")..];
    let (mut checked, mut files) = (0, 0);
    for line in code.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")) {
        if line.starts_with("import ") {
            continue;
        }
        if let Some((_, file)) = line.strip_prefix("const ").and_then(|l| l.split_once("Url = '")) {
            let file = file.trim_end_matches("';");
            assert!(out.join(file).is_file(), "{line}: no such file written");
            files += 1;
        } else {
            assert!(page_lines.contains(&line), "not a line of clients/playcanvas-web/render.js: {line}");
            checked += 1;
        }
    }
    assert_eq!((checked, files), (9, 2), "{code}");
    // The atlas: 512 x 512 RGBA, black between the rects, the map's grey in the ambient rect.
    let atlas =
        image::load_from_memory(&common::read_file(&out.join("bright_envAtlas.png"))).expect("a PNG").to_rgba8();
    assert_eq!(atlas.dimensions(), (512, 512));
    assert_eq!(from_rgbp(atlas.get_pixel(300, 450).0), [0.0; 3]);
    let a = playcanvas_atlas::AMBIENT;
    let ambient = from_rgbp(atlas.get_pixel((a.x + a.w / 2) as u32, (a.y + 2) as u32).0);
    assert!(ambient[0] > 0.45, "{ambient:?}");
}

/// The sun the README adds back (issue 36, `common/sun_lines.rs`): the park map baked with `--sun
/// extract`, the atlas and skybox loaded by the README's lines and its sun lines run as they are,
/// against the `--sun keep` bake in the same page: the diffuse sphere within [`SUN_BOUND`], each
/// mistake beyond it; the metal of roughness 0.5 reported.
#[test]
fn playcanvas_adds_the_readmes_sun_as_the_map_held_it() {
    let Some(browser) = browser() else { return };
    let sandbox = common::Sandbox::new();
    let bakes = sun_lines::bake_park(&sandbox, "playcanvas");
    let renders = sun_lines::scene_renders(&sandbox, &bakes, |name, dir| {
        let files = Files { atlas: dir.join("park_envAtlas.png"), sky: dir.join("park_skybox.png") };
        job_entry(&sandbox, name, &files)
    });
    let job = json!({ "renders": renders });
    let page = web_page::run_with_budget(
        browser,
        &app_dir(),
        &sandbox,
        &job,
        "playcanvas-render/sun",
        BROWSER_TIMEOUT,
        VIRTUAL_TIME_BUDGET_MS,
    );
    for r in page.report["renders"].as_array().expect("the renders") {
        assert_eq!(r["stable"], true, "{}: the second frame differs from the first", r["name"]);
    }
    sun_lines::assert_scene_sun("PlayCanvas", &sandbox, &page, &bakes, SUN_BOUND);
}
