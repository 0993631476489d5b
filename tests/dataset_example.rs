//! The worked dataset example (issue 26), `examples/dataset/dataset.ron`, run as its README runs
//! it, through `hdrflow batch`, on one CC0 map at the 8 azimuths: the files (8 azimuths x 4
//! crops, each an EXR and a JSON label), the labels' keys exactly, their parts equal to what
//! `ShIrradiance`, `SphericalGaussians` and `ExtractLights` save, the cameras as the pipeline
//! declares them, the lighting turning with the azimuth as `Rotate` says, a rerun served from
//! the cache, the Slurm form, and a label wired wrongly refused before anything runs.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::*;
use serde_json::Value as Json;

const GRAPH: &str = "examples/dataset/dataset.ron";
const MAP: &str = "assets/maps/rooitou_park_1k.hdr";
const YAWS: [f64; 8] = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0];
/// The crops' (yaw, pitch) in `dataset.ron`, roll 0, fov 60, 256 x 256.
const CROPS: [(f64, f64); 4] = [(-16.875, 0.0), (-5.625, 10.0), (5.625, -10.0), (16.875, 5.0)];

/// The example's batch command (the README's, on one map, with 3 fit rounds instead of 30 to
/// stay quick), into `out`.
fn batch_args(sb: &Sandbox, out: &Path, extra: &[&str]) -> Vec<String> {
    let sweep = YAWS.map(|y| y.to_string()).join(",");
    let mut args: Vec<String> = [
        "batch",
        GRAPH,
        "--over",
        &format!("env.path={MAP}"),
        "--sweep",
        &format!("rot.yaw={sweep}"),
        "--sweep",
        "sg.iterations=3",
        "--item-dir",
        "{stem}/yaw={rot.yaw}",
        "--out",
        &out.display().to_string(),
        "--cache-dir",
        &sb.cache().display().to_string(),
    ]
    .map(String::from)
    .to_vec();
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

fn json(path: &Path) -> Json {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn keys(v: &Json) -> Vec<&str> {
    v.as_object().unwrap_or_else(|| panic!("not an object: {v}")).keys().map(String::as_str).collect()
}

fn triple(v: &Json) -> [f64; 3] {
    let a: Vec<f64> = v.as_array().expect("an array").iter().map(|x| x.as_f64().expect("a number")).collect();
    a.try_into().expect("three numbers")
}

/// `R_y(yaw) R_x(pitch)` (degrees), written out here rather than taken from the crate.
fn rotation(yaw: f64, pitch: f64) -> [[f64; 3]; 3] {
    let (sy, cy) = yaw.to_radians().sin_cos();
    let (sp, cp) = pitch.to_radians().sin_cos();
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rx = [[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]];
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| ry[i][k] * rx[k][j]).sum();
        }
    }
    m
}

fn apply(m: [[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

fn item_dir(out: &Path, yaw: f64) -> PathBuf {
    out.join(format!("rooitou_park_1k/yaw={yaw}"))
}

#[test]
fn the_dataset_example_writes_four_labelled_crops_per_azimuth() {
    let sb = Sandbox::new();
    let out = sb.out();
    let report = sb.next_report();
    let run = run_hdrflow(batch_args(&sb, &out, &["--report", &report.display().to_string()]));
    run.assert_success();

    // The files: per azimuth 4 crops and 4 labels, and the azimuth's own targets.
    let mut want = BTreeSet::new();
    for yaw in YAWS {
        for k in 0..4 {
            want.insert(format!("rooitou_park_1k/yaw={yaw}/crop_{k}.exr"));
            want.insert(format!("rooitou_park_1k/yaw={yaw}/crop_{k}.json"));
        }
        for f in ["sh", "lobes", "sg_fit", "lights"] {
            want.insert(format!("rooitou_park_1k/yaw={yaw}/map/{f}.json"));
        }
    }
    // The report's metrics by node and their summary (the fit's relative_rmse and size).
    want.extend(["metrics.csv", "summary.csv", "summary.md"].map(String::from));
    let got: BTreeSet<String> = files_under(&out)
        .iter()
        .map(|p| p.to_string_lossy().replace('\\', "/"))
        .filter(|p| !p.starts_with("batch"))
        .collect();
    assert_eq!(got, want);
    let rows = json(&report);
    let rows = rows.as_array().expect("a JSON array");
    assert_eq!(rows.len(), 8);
    assert!(rows.iter().all(|r| r["status"] == "computed"), "{rows:?}");

    let mut first_light = Vec::new();
    let mut band1 = Vec::new();
    for yaw in YAWS {
        let dir = item_dir(&out, yaw);
        let (sh, lobes, lights) =
            (json(&dir.join("map/sh.json")), json(&dir.join("map/lobes.json")), json(&dir.join("map/lights.json")));
        for (k, (cyaw, cpitch)) in CROPS.into_iter().enumerate() {
            let exr = read_file(&dir.join(format!("crop_{k}.exr")));
            assert_eq!(&exr[..4], &[0x76, 0x2f, 0x31, 0x01], "crop_{k}.exr is an EXR");
            let label = json(&dir.join(format!("crop_{k}.json")));
            // The keys, exactly, in this order.
            assert_eq!(keys(&label), ["camera", "sh", "spherical_gaussians", "lights"]);
            let cam = &label["camera"];
            assert_eq!(keys(cam), ["model", "fov", "width", "height", "yaw", "pitch", "roll", "world_to_camera"]);
            assert_eq!(keys(&label["sh"]), ["frame", "order", "basis", "coefficients"]);
            assert_eq!(keys(&label["spherical_gaussians"]), ["lobes"]);
            for lobe in label["spherical_gaussians"]["lobes"].as_array().unwrap() {
                assert_eq!(keys(lobe), ["axis", "sharpness", "amplitude"]);
            }
            assert_eq!(keys(&label["lights"]), ["lights", "ambient"]);
            for light in label["lights"]["lights"].as_array().unwrap() {
                assert_eq!(keys(light), ["direction", "solid_angle", "radiance"]);
            }
            // The parts are what the operators save, number for number.
            assert_eq!(label["sh"], sh, "yaw {yaw} crop {k}");
            assert_eq!(label["spherical_gaussians"], lobes);
            assert_eq!(label["lights"], lights);
            // The camera is the crop's, as dataset.ron declares it.
            assert_eq!(cam["model"], "Perspective");
            assert_eq!((cam["width"].as_u64(), cam["height"].as_u64()), (Some(256), Some(256)));
            assert_eq!(cam["fov"].as_f64(), Some(60.0));
            assert_eq!(
                (cam["yaw"].as_f64(), cam["pitch"].as_f64(), cam["roll"].as_f64()),
                (Some(cyaw), Some(cpitch), Some(0.0))
            );
            // world_to_camera is R^T: it takes the crop's centre ray R (0, 0, -1) to (0, 0, -1).
            let m: Vec<[f64; 3]> = cam["world_to_camera"].as_array().unwrap().iter().map(triple).collect();
            let m: [[f64; 3]; 3] = m.try_into().expect("3 rows");
            let r = rotation(cyaw, cpitch);
            for i in 0..3 {
                for j in 0..3 {
                    assert!((m[i][j] - r[j][i]).abs() < 1e-12, "world_to_camera[{i}][{j}]");
                }
            }
            let centre = apply(m, apply(r, [0.0, 0.0, -1.0]));
            assert!((centre[0].abs() + centre[1].abs() + (centre[2] + 1.0).abs()) < 1e-12, "{centre:?}");
        }
        // The targets' sizes: SH order 2, 12 lobes, 1 to 3 lights (the park has a sun).
        assert_eq!(sh["order"], 2);
        assert_eq!(sh["coefficients"].as_array().map(Vec::len), Some(9));
        assert_eq!(lobes["lobes"].as_array().map(Vec::len), Some(12));
        let n = lights["lights"].as_array().map_or(0, Vec::len);
        assert!((1..=3).contains(&n), "{n} lights");
        first_light.push(triple(&lights["lights"][0]["direction"]));
        let c = &sh["coefficients"];
        band1.push([triple(&c[0]), triple(&c[3]), triple(&c[1]), triple(&c[2])]);
    }

    // The lighting is in the rotated map's frame: the azimuth turns it by R_y(yaw) (Rotate moves
    // what is seen in direction v to R v). The sun moves with it; L_00 stays; the l = 1 band,
    // (L_11, L_1-1, L_10) ~ (x, y, z), turns as a vector (whole-column rolls: exact to rounding).
    for (i, yaw) in YAWS.into_iter().enumerate() {
        let r = rotation(yaw, 0.0);
        let sun = apply(r, first_light[0]);
        let d = first_light[i];
        assert!((0..3).all(|j| (sun[j] - d[j]).abs() < 1e-9), "yaw {yaw}: sun {d:?}, expected {sun:?}");
        let [l00, x, y, z] = band1[i];
        let [l00_0, x0, y0, z0] = band1[0];
        for ch in 0..3 {
            assert!((l00[ch] - l00_0[ch]).abs() < 1e-9 * l00_0[ch].abs(), "yaw {yaw}: L_00");
            let want = apply(r, [x0[ch], y0[ch], z0[ch]]);
            let have = [x[ch], y[ch], z[ch]];
            assert!(
                (0..3).all(|j| (want[j] - have[j]).abs() < 1e-9 * l00_0[ch].abs()),
                "yaw {yaw}: band 1 {have:?} vs {want:?}"
            );
        }
    }

    // A rerun recomputes nothing and rewrites nothing.
    let before = batch_outputs(&out);
    let report = sb.next_report();
    run_hdrflow(batch_args(&sb, &out, &["--report", &report.display().to_string()])).assert_success();
    let rows = json(&report);
    assert!(rows.as_array().unwrap().iter().all(|r| r["status"] == "cached"), "{rows:?}");
    assert_eq!(batch_outputs(&out), before);
}

#[test]
fn the_example_readme_gives_the_commands_this_test_runs_and_a_slurm_script() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/dataset/README.md")).unwrap();
    for needle in [
        "hdrflow batch examples/dataset/dataset.ron",
        "--over env.path='assets/maps/*.hdr'",
        "--sweep rot.yaw=0,45,90,135,180,225,270,315",
        "--emit-slurm",
    ] {
        assert!(readme.contains(needle), "examples/dataset/README.md lacks {needle:?}");
    }
    // The Slurm form writes a job array of one element per item and runs nothing.
    let sb = Sandbox::new();
    let script = sb.join("dataset.sbatch");
    let out = sb.out();
    let run = run_hdrflow(batch_args(&sb, &out, &["--emit-slurm", &script.display().to_string(), "--shards", "8"]));
    run.assert_success();
    let text = std::fs::read_to_string(&script).expect("the script");
    assert!(text.contains("#SBATCH --array=0-7"), "{text}");
    assert!(text.contains("rot.yaw=0,45,90,135,180,225,270,315"), "{text}");
    assert!(text.contains("dataset.ron"), "{text}");
    assert!(!files_under(&out).iter().any(|p| p.extension().is_some_and(|e| e == "json" || e == "exr")), "ran nothing");
}

#[test]
fn a_label_wired_to_the_wrong_values_is_refused_before_anything_runs() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "bad.ron",
        r#"(nodes: {
    "env":   LoadHdr(path: "builtin:sky"),
    "crop":  Project(env: "env", width: 8, height: 8, fov: 60),
    "sg":    SphericalGaussians(env: "env", lobes: 2),
    "label": CropLabel(camera: "crop", sh: "sg"),
    "save":  Save(input: "label", path: "label.json"),
    "save2": Save(input: "crop.camera", path: "camera.exr"),
})"#,
    );
    let (out, _) = sb.run(&graph, &[]);
    out.assert_code(2);
    out.assert_stderr_contains(
        r#"bad.ron:5:32: node "label": field "camera" expects camera, but node "crop" (Project) gives image"#,
    );
    out.assert_stderr_contains(
        r#"node "label": field "sh" expects sh coefficients, but node "sg" (SphericalGaussians) gives sg"#,
    );
    out.assert_stderr_contains(r#"cannot save a value of type camera as ".exr": use one of .json"#);
    assert!(files_under(&sb.out()).is_empty());
}
