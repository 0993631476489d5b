//! What the Babylon.js render tests share (tests/babylon_render.rs: a `.env`; tests/gltf_render.rs:
//! a glTF asset's `EXT_lights_image_based` light): the client (`clients/babylon-web`), its pinned
//! packages, the run of its page, the sphere scene's camera and bounds, the shader pieces the
//! reference models, the table of errors, and the RGBD-without-gamma mistake. Included by `#[path]`
//! as `babylon_page`, beside `common`, `web_page`, `reference` (Bevy's), `scene` and
//! `babylon_reference`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use glam::DVec3;
use hdrflow::values::Image;
use serde_json::Value as Json;

use crate::babylon_reference::SphereReference;
use crate::reference::relative_rmse;
use crate::scene::Geometry;
use crate::{common, web_page};

pub const REQUIRE: &str = "HDRFLOW_REQUIRE_BABYLON";
/// The pinned engine (clients/babylon-web/package-lock.json).
pub const PACKAGE_VERSION: &str = "9.37.1";
/// The orthographic camera of the sphere renders (clients/web-common/scene.js: on +Z at CAMERA_Z).
pub const CAMERA: DVec3 = DVec3::new(0.0, 0.0, 10.0);
/// Relative RMSE bounds per sphere (mirror, metals 0.25, 0.5, 0.75, 1, diffuse) on the test map:
/// about twice what the correct bake measures (0.0146, 0.0095, 0.0017, 0.0008, 0.0002, 0.0002:
/// docs/src/guides/baking/babylon.md), at least 0.002.
pub const TEST_MAP_BOUNDS: [f64; 6] = [0.03, 0.02, 0.005, 0.003, 0.002, 0.002];
/// SwiftShader is a CPU renderer on a shared machine: a minute is possible, ten are a hang.
pub const BROWSER_TIMEOUT: Duration = Duration::from_secs(600);

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

pub fn write_map(sandbox: &common::Sandbox, name: &str, img: &Image) -> PathBuf {
    sandbox.write(name, hdrflow::formats::pfm::encode(img))
}

pub fn rel(sandbox: &common::Sandbox, p: &Path) -> String {
    p.strip_prefix(sandbox.path()).expect("inside the sandbox").to_str().expect("UTF-8").to_string()
}

/// The pieces of Babylon's PBR shader `babylon_render/reference.rs` models, in the GLSL it
/// compiled (an upgrade that changes them must revisit the reference).
pub const SPHERE_SHADER: [&str; 4] = [
    "reflectionLOD=reflectionLOD*vReflectionMicrosurfaceInfos.y+vReflectionMicrosurfaceInfos.z",
    "float lod=log2(microsurfaceAverageSlopeTexels)",
    "mix(environmentRadiance.rgb,environmentIrradiance,alphaG)",
    "return 1.0+specularEnvironmentR0*(1.0/environmentBrdf.y-1.0)",
];

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
    let page = web_page::run(browser, &app_dir(), sandbox, job, &format!("{keep}/{label}"), BROWSER_TIMEOUT);
    assert_eq!(page.report["package"], PACKAGE_VERSION, "the pinned engine (clients/babylon-web/package-lock.json)");
    for r in page.report["renders"].as_array().expect("the renders") {
        assert_eq!(r["stable"], true, "{}: the second frame differs from the first", r["name"]);
        assert_eq!(r["loaded"]["lodGenerationScale"], lod_scale, "{r}");
    }
    page
}

/// Relative RMSE per sphere against the `engine` references (printed with the exact ones).
pub fn errors(label: &str, frame: &Image, geometry: &Geometry, refs: &[SphereReference]) -> Vec<f64> {
    eprintln!(
        "{label}: relative RMSE per sphere (vs Babylon's formula on exact lookups | vs exact GGX and irradiance)"
    );
    let mut out = Vec::new();
    for (s, r) in geometry.spheres.iter().zip(refs) {
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
