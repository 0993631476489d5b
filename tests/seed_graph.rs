//! `graphs/seed.ron` end to end, and the relighting operators against closed forms.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::values::{Image, SampleSet};
use hdrflow::{Pipeline, Value};

const SEED_FILES: &[&str] = &[
    "em_64.png",
    "em_256.png",
    "em_1024.png",
    "phong_exponent1.png",
    "phong_exponent10.png",
    "phong_exponent50.png",
    "phong_exponent200.png",
    "sphere_64.png",
    "sphere_256.png",
    "sphere_1024.png",
    "fresnel_air_to_glass.png",
    "fresnel_glass_to_air.png",
    "em_64.csv",
    "em_256.csv",
    "em_1024.csv",
    "phong_exponent1.csv",
    "phong_exponent200.csv",
    "fresnel_air_to_glass.csv",
    "fresnel_glass_to_air.csv",
    "fresnel_air_to_glass.json",
    "glossy_s1.png",
    "glossy_s10.png",
    "glossy_s50.png",
    "glossy_s200.png",
    "glossy_s10.exr",
    "glossy_s200.exr",
];

/// Runs pipeline text in-process and returns the values of the named targets.
fn run_targets(text: &str, targets: &[&str]) -> BTreeMap<String, Value> {
    let registry = hdrflow::builtin_registry();
    let p = Pipeline::parse(text, "test.ron", Path::new("."), &registry, &[]).expect("valid pipeline");
    let out = tempfile::tempdir().unwrap();
    let options = RunOptions {
        targets: targets.iter().map(|t| t.to_string()).collect(),
        out_dir: out.path().into(),
        cache: None,
        jobs: None,
        observer: &Silent,
    };
    scheduler::run(&p, &options).expect("runs").values
}

fn image(values: &BTreeMap<String, Value>, name: &str) -> Image {
    values[name].get::<Image>().expect("an image").clone()
}

/// Pixels on the disc (any non-zero channel).
fn disc_pixels(img: &Image) -> Vec<[f32; 3]> {
    (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| img.rgb(x, y))
        .filter(|p| p.iter().any(|&c| c != 0.0))
        .collect()
}

#[test]
fn seed_graph_writes_every_seed_file_and_reruns_from_cache() {
    let dir = tempfile::tempdir().unwrap();
    let (out, cache, report) = (dir.path().join("out"), dir.path().join("cache"), dir.path().join("r.json"));
    let run = || {
        Command::new(env!("CARGO_BIN_EXE_hdrflow"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(["run", "graphs/seed.ron", "-q", "--out"])
            .arg(&out)
            .arg("--cache-dir")
            .arg(&cache)
            .arg("--report")
            .arg(&report)
            .output()
            .unwrap()
    };
    let first = run();
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    for f in SEED_FILES {
        let path = out.join(f);
        assert!(path.is_file(), "missing {f}");
        assert!(std::fs::metadata(&path).unwrap().len() > 0, "empty {f}");
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("fresnel_air_to_glass.json")).unwrap()).unwrap();
    assert!((json["brewster_deg"].as_f64().unwrap() - 56.3099).abs() < 1e-4);
    assert!(json["critical_deg"].is_null());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("fresnel_glass_to_air.json")).unwrap()).unwrap();
    assert!((json["critical_deg"].as_f64().unwrap() - 41.8103).abs() < 1e-4);
    let csv = std::fs::read_to_string(out.join("em_1024.csv")).unwrap();
    assert!(csv.starts_with("index,x,y,theta,phi,dx,dy,dz,pdf\n"));
    assert_eq!(csv.lines().count(), 1025);

    let second = run();
    assert!(second.status.success());
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let computed: Vec<&str> = r["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n["status"] == "computed")
        .map(|n| n["name"].as_str().unwrap())
        .collect();
    assert!(computed.is_empty(), "a rerun computed {computed:?}");
}

const CONSTANT: &str = r#"(nodes: {
    "env": LoadHdr(path: "builtin:constant"),
    "lum": Luminance(image: "env"),
    "cdf": BuildCdf(luminance: "lum"),
    "s":   Sample(cdf: "cdf", count: 4096, seed: 3, sequence: Stratified),
    "u":   RelightSphere(env: "env", samples: "s", size: 64, albedo: (0.5, 0.25, 1.0)),
    "k":   RelightSphere(env: "env", samples: "s", size: 64, albedo: (0.5, 0.25, 1.0), estimator: Seed),
})"#;

#[test]
fn constant_environment_relights_to_albedo_with_the_unbiased_estimator() {
    let v = run_targets(CONSTANT, &["u"]);
    let img = image(&v, "u");
    let px = disc_pixels(&img);
    assert!(px.len() > 3000, "{} pixels on the disc", px.len());
    let albedo = [0.5f64, 0.25, 1.0];
    for c in 0..3 {
        let mean = px.iter().map(|p| p[c] as f64).sum::<f64>() / px.len() as f64;
        assert!((mean / albedo[c] - 1.0).abs() < 5e-3, "channel {c}: mean {mean} vs albedo {}", albedo[c]);
        for p in &px {
            assert!(
                (p[c] as f64 / albedo[c] - 1.0).abs() < 0.03,
                "channel {c}: pixel {} vs albedo {}",
                p[c],
                albedo[c]
            );
        }
    }
}

#[test]
fn seed_estimator_is_one_over_sqrt3_of_the_unbiased_one_under_grey_light() {
    // With a constant map the pdf is the same for every texel, so the two estimators differ
    // only by rgb/|rgb| = 1/sqrt(3) against rgb/Y = 1 (and the midpoint-rule total solid angle).
    let v = run_targets(CONSTANT, &["u", "k"]);
    let (u, k) = (image(&v, "u"), image(&v, "k"));
    for (pu, pk) in u.data.iter().zip(&k.data) {
        if *pu > 0.0 {
            let ratio = *pk as f64 / *pu as f64;
            assert!((ratio - 1.0 / 3f64.sqrt()).abs() < 2e-3, "ratio {ratio}");
        } else {
            assert_eq!(*pk, 0.0);
        }
    }
}

#[test]
fn hemisphere_environment_relights_to_albedo_times_one_plus_ny_over_two() {
    // Upper hemisphere lit: Lo(n) = albedo * (1 + n_y) / 2 (the closed form in NOTES.md). Seen
    // from the side, n_y runs from +1 at the top of the disc to -1 at the bottom.
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:hemisphere"),
        "lum": Luminance(image: "env"),
        "cdf": BuildCdf(luminance: "lum"),
        "s":   Sample(cdf: "cdf", count: 16384, seed: 5, sequence: Sobol),
        "u":   RelightSphere(env: "env", samples: "s", size: 33, view: (90.0, 0.0)),
    })"#;
    let img = image(&run_targets(text, &["u"]), "u");
    let size = img.width;
    for py in [4, 8, 12, 16, 20, 24, 28] {
        let px = size / 2;
        let sy = 1.0 - 2.0 * (py as f64 + 0.5) / size as f64; // n_y at the disc's centre column
        let want = (1.0 + sy) / 2.0;
        let got = img.rgb(px, py)[0] as f64;
        assert!((got - want).abs() < 0.03, "row {py}: {got} vs {want}");
    }
}

#[test]
fn samples_are_reproducible_for_a_seed_whatever_the_thread_count() {
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:studio"),
        "lum": Luminance(image: "env"),
        "cdf": BuildCdf(luminance: "lum"),
        "s":   Sample(cdf: "cdf", count: 5000, seed: 11),
        "p":   PhongSample(exponent: 37.0, count: 5000, seed: 11, sequence: Sobol),
    })"#;
    let registry = hdrflow::builtin_registry();
    let p = Pipeline::parse(text, "t.ron", Path::new("."), &registry, &[]).unwrap();
    let mut results = Vec::new();
    for jobs in [1, 2, 4] {
        let out = tempfile::tempdir().unwrap();
        let o = RunOptions {
            targets: vec![],
            out_dir: out.path().into(),
            cache: None,
            jobs: Some(jobs),
            observer: &Silent,
        };
        let v = scheduler::run(&p, &o).unwrap().values;
        results.push((
            v["s"].get::<SampleSet>().unwrap().samples.clone(),
            v["p"].get::<SampleSet>().unwrap().samples.clone(),
        ));
    }
    assert_eq!(results[0], results[1]);
    assert_eq!(results[0], results[2]);
}

#[test]
fn grace_cathedral_runs_with_one_set() {
    let grace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/envmaps/grace-new_256x128.hdr");
    if !grace.is_file() {
        common::skip_missing_data(&format!("{} not found; the Grace Cathedral run did not happen", grace.display()));
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hdrflow"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "run",
            "graphs/seed.ron",
            "-q",
            "--no-cache",
            "--set",
            "env.path=../shared/data/envmaps/grace-new_256x128.hdr",
        ])
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in SEED_FILES {
        assert!(dir.path().join(f).is_file(), "missing {f}");
    }
    let csv = std::fs::read_to_string(dir.path().join("em_64.csv")).unwrap();
    // Samples refer to the 256x128 map's texels.
    for line in csv.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        assert!(cols[1].parse::<u32>().unwrap() < 256 && cols[2].parse::<u32>().unwrap() < 128, "{line}");
    }
}
