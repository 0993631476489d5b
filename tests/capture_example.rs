//! The capture example (issue 38), `examples/capture/`, run as its README runs it: the
//! photographs made by `make_captures.ron` through `hdrflow batch` (JPEG brackets with EXIF
//! times), then `capture.ron` over the capture folders: every file written, the shifts found
//! equal to the camera shake the photographs were made with, the merged ball against the
//! radiance it was made from, the calibrated map's illuminance equal to the lux asked for, and a
//! rerun served from the cache.

mod common;

use std::path::Path;

use common::*;
use hdrflow::values::Image;
use serde_json::Value as Json;

/// The interior: light through windows and a lit room, every exposure holding texture. (On the
/// park's ball the 1/4000 s frame holds little but the sun, and the studio's balls are mostly
/// black: their darkest frames' bitmaps are noise and align within a pixel or two at best.)
const MAP: &str = "assets/maps/st_fagans_interior_1k.hdr";
const ITEM: &str = "st_fagans_interior_1k";

fn json(path: &Path) -> Json {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn exr(path: &Path) -> Image {
    hdrflow::formats::decode_by_extension(&read_file(path), "exr").unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The median of |s m / t - 1| over the channels where the truth is positive, `s` the scale that makes the median ratio 1 (a merge recovers radiance up to
/// a scale): the "median relative error after the best scale".
fn median_relative_error(merged: &Image, truth: &Image) -> f64 {
    let mut ratios = Vec::new();
    for i in 0..truth.pixel_count() {
        for c in 0..3 {
            let (m, t) = (merged.data[i * merged.channels + c] as f64, truth.data[i * truth.channels + c] as f64);
            assert!(m.is_finite(), "pixel {i} channel {c} is {m}");
            if t > 0.0 {
                ratios.push(m / t);
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let s = 1.0 / median(&mut ratios);
    let mut rel: Vec<f64> = ratios.iter().map(|r| (s * r - 1.0).abs()).collect();
    median(&mut rel)
}

#[test]
fn the_capture_example_runs_as_its_readme_says() {
    let sb = Sandbox::new();
    let (captures, out) = (sb.join("captures"), sb.join("capture"));
    let cache = sb.cache().display().to_string();
    run_hdrflow([
        "batch",
        "examples/capture/make_captures.ron",
        "--over",
        &format!("env.path={MAP}"),
        "--out",
        &captures.display().to_string(),
        "--cache-dir",
        &cache,
    ])
    .assert_success();
    let folder = captures.join(ITEM);
    for k in 0..5 {
        assert!(folder.join(format!("shot_{k}.jpg")).is_file(), "shot_{k}.jpg missing in {}", folder.display());
    }
    let report = sb.join("batch.json");
    let args = [
        "batch".to_string(),
        "examples/capture/capture.ron".into(),
        "--over".into(),
        format!("brackets.paths={}/*/", captures.display()),
        "--out".into(),
        out.display().to_string(),
        "--cache-dir".into(),
        cache.clone(),
        "--report".into(),
        report.display().to_string(),
    ];
    // The README's Slurm form: a job array over the capture folders, nothing run.
    let readme = std::fs::read_to_string(Path::new(common::MANIFEST_DIR).join("examples/capture/README.md")).unwrap();
    assert!(readme.contains("--out out/capture --emit-slurm capture.sbatch"), "the README's Slurm command");
    let script = sb.join("capture.sbatch");
    let mut slurm = args[..8].to_vec();
    slurm.extend(["--emit-slurm".to_string(), script.display().to_string()]);
    run_hdrflow(&slurm).assert_success();
    let text = std::fs::read_to_string(&script).expect("the job script");
    assert!(text.contains("#SBATCH --array=0-0") && text.contains("capture.ron"), "{text}");
    assert!(!out.join(ITEM).join("map.exr").exists(), "--emit-slurm runs nothing");

    run_hdrflow(&args).assert_success();
    let rows = json(&report);
    assert!(rows.as_array().is_some_and(|r| r.len() == 1 && r[0]["status"] == "computed"), "{rows}");
    let item = out.join(ITEM);
    for f in [
        "map.exr",
        "ball.exr",
        "preview.png",
        "response.csv",
        "response.svg",
        "merge.json",
        "shifts.json",
        "illuminance.json",
    ] {
        assert!(item.join(f).is_file(), "{f} missing in {}", item.display());
    }
    assert!(out.join("batch.csv").is_file());

    // The merged ball against the radiance the photographs were made from, every channel whose
    // truth is positive (clipped ones hold the shortest exposure's value and count as they are).
    let truth = exr(&folder.join("truth/ball.exr"));
    let ball = exr(&item.join("ball.exr"));
    assert_eq!((ball.width, ball.height), (truth.width, truth.height));
    let err = median_relative_error(&ball, &truth);
    assert!(err < 0.05, "the merged ball is {err:.4} off the truth (median relative, after the best scale)");

    // The shifts: make_captures.ron shook the camera by (2, -1), (1, 0), (0, 0), (-1, 2), (-3, 1);
    // aligning moves each frame back onto the middle one.
    let shifts = json(&item.join("shifts.json"));
    let got: Vec<(f64, f64)> = (0..5)
        .map(|k| (shifts[format!("dx_{k}")].as_f64().unwrap(), shifts[format!("dy_{k}")].as_f64().unwrap()))
        .collect();
    assert_eq!(got, [(-2.0, 1.0), (-1.0, 0.0), (0.0, 0.0), (1.0, -2.0), (3.0, -1.0)], "{shifts}");

    // The map is calibrated to the lux asked for.
    let lux = json(&item.join("illuminance.json"));
    let after = lux["illuminance_after"].as_f64().unwrap();
    assert!((after / 20000.0 - 1.0).abs() < 1e-6, "{lux}");

    // A rerun is served from the cache.
    run_hdrflow(&args).assert_success();
    let rows = json(&report);
    assert!(rows.as_array().is_some_and(|r| r[0]["status"] == "cached"), "{rows}");
}
