//! `graphs/compositing.ron` end to end through the library, checked against closed forms: the
//! generic image operators (SplitChannels, MergeChannels, Math, Crop, Blur, Tonemap, Difference,
//! Exposure with alpha) on the built-in sky.

use std::collections::BTreeMap;
use std::path::Path;

use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::values::{Image, Metrics};
use hdrflow::{Pipeline, Value};

const GRAPH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/graphs/compositing.ron");

/// Runs the pipeline with every node as a target; returns the values and the output folder.
fn run_all() -> (BTreeMap<String, Value>, tempfile::TempDir) {
    let registry = hdrflow::builtin_registry();
    let p = Pipeline::load(Path::new(GRAPH), &registry, &[]).expect("graphs/compositing.ron is valid");
    let out = tempfile::tempdir().unwrap();
    let options = RunOptions {
        targets: p.nodes.iter().map(|n| n.name.clone()).collect(),
        out_dir: out.path().into(),
        cache: None,
        jobs: None,
        observer: &Silent,
    };
    let outcome = scheduler::run(&p, &options).expect("graphs/compositing.ron runs");
    (outcome.values, out)
}

fn image<'a>(values: &'a BTreeMap<String, Value>, name: &str) -> &'a Image {
    values.get(name).unwrap_or_else(|| panic!("no value {name:?}")).get::<Image>().expect("an image")
}

#[test]
fn compositing_graph_matches_its_closed_forms() {
    let (v, out) = run_all();
    let env = image(&v, "env");
    let (w, h) = (env.width, env.height);
    assert_eq!((w, h, env.names.join("")), (512, 256, "RGB".to_string()));

    // Merge(Split) round-trips bit for bit, names included.
    let merged = image(&v, "merged");
    assert_eq!(merged, env);
    assert!(merged.data.iter().zip(&env.data).all(|(a, b)| a.to_bits() == b.to_bits()));
    // `swapped` exchanges R and B.
    let swapped = image(&v, "swapped");
    for (s, e) in swapped.data.chunks_exact(3).zip(env.data.chunks_exact(3)) {
        assert_eq!([s[0], s[1], s[2]], [e[2], e[1], e[0]]);
    }
    // Each SplitChannels port is its channel, as a scalar field named like it.
    for (k, name) in ["R", "G", "B"].iter().enumerate() {
        let ch = image(&v, &format!("split.{name}"));
        assert_eq!((ch.channels, ch.names.clone()), (1, vec![name.to_string()]));
        assert!(ch.data.iter().zip(env.data.iter().skip(k).step_by(3)).all(|(a, b)| a == b));
    }

    // Math: an image minus its copy is 0; Min with a number clamps; colour / luminance.
    assert!(image(&v, "zero").data.iter().all(|&x| x == 0.0));
    let no_sun = image(&v, "no_sun");
    for (n, e) in no_sun.data.iter().zip(&env.data) {
        assert_eq!(*n, e.min(4.0));
    }
    let (lum, chroma) = (image(&v, "lum"), image(&v, "chroma"));
    for (i, px) in chroma.data.chunks_exact(3).enumerate() {
        for (k, c) in px.iter().enumerate() {
            assert_eq!(*c, (env.data[3 * i + k] as f64 / lum.data[i] as f64) as f32);
        }
    }

    // Crop: the rows 96..160 of env.
    let horizon = image(&v, "horizon");
    assert_eq!((horizon.width, horizon.height), (512, 64));
    for j in 0..64 {
        assert_eq!(horizon.row(j), env.row(96 + j));
    }

    // Blur of a constant is the constant; a blurred sky keeps each row's horizontal structure
    // bounded by the sharp map's range.
    let flat = image(&v, "flat_blur");
    assert!(flat.data.iter().all(|&x| (x - 0.25).abs() <= 1e-7), "blurred constant");
    let soft = image(&v, "soft");
    let max_sharp = no_sun.data.iter().cloned().fold(0.0f32, f32::max);
    assert!(soft.data.iter().all(|&x| (0.0..=max_sharp * (1.0 + 1e-6)).contains(&x)));

    // Tonemap: display values in [0, 1]; the matte's alpha is min(Y, 1) and survives Exposure.
    let display = image(&v, "display");
    assert!(display.data.iter().all(|x| (0.0..=1.0).contains(x)));
    let (rgba, dim) = (image(&v, "rgba"), image(&v, "rgba_dim"));
    assert_eq!(dim.names, vec!["R", "G", "B", "A"]);
    for (i, (p, d)) in rgba.data.chunks_exact(4).zip(dim.data.chunks_exact(4)).enumerate() {
        assert_eq!(p[3], lum.data[i].min(1.0));
        assert_eq!(d[3], p[3], "alpha unchanged by Exposure");
        assert_eq!([d[0], d[1], d[2]], [p[0] * 0.5, p[1] * 0.5, p[2] * 0.5]);
    }

    // Difference: three ports; the metrics are those of the raw field.
    let heat = image(&v, "diff");
    assert_eq!((heat.width, heat.height, heat.channels), (w, h + 28, 3));
    let err = image(&v, "diff.error");
    let m = v["diff.metrics"].get::<Metrics>().expect("metrics");
    let n = err.data.len() as f64;
    let mean = err.data.iter().map(|&x| x as f64).sum::<f64>() / n;
    let rmse = (err.data.iter().map(|&x| (x as f64).powi(2)).sum::<f64>() / n).sqrt();
    let max = err.data.iter().cloned().fold(0.0f32, f32::max) as f64;
    assert!((m.get("mean").unwrap() - mean).abs() <= 1e-12 * mean);
    assert!((m.get("rmse").unwrap() - rmse).abs() <= 1e-12 * rmse);
    assert_eq!(m.get("max"), Some(max));
    assert_eq!(m.get("nonfinite"), Some(0.0));
    // The blur moves most error to the horizon, where sky meets ground.
    let row_mean = |y: usize| err.row(y).iter().map(|&x| x as f64).sum::<f64>() / w as f64;
    assert!(row_mean(h / 2) > 10.0 * row_mean(h / 8));

    // Every Save wrote its file.
    for f in [
        "sky_agx.png",
        "sky_red_blue_swapped.png",
        "sky_chromaticity.png",
        "horizon.exr",
        "sky_soft_aces.png",
        "sky_matte_rgba.png",
        "sky_matte_rgba.exr",
        "blur_error.png",
        "blur_error.exr",
        "blur_error.json",
    ] {
        let path = out.path().join("compositing").join(f);
        assert!(path.metadata().map(|m| m.len() > 0).unwrap_or(false), "{} missing", path.display());
    }
}

/// Runs pipeline text in-process and returns the error message of the run.
fn run_error(text: &str) -> String {
    let registry = hdrflow::builtin_registry();
    let p = Pipeline::parse(text, "t.ron", Path::new("."), &registry, &[]).expect("valid pipeline");
    let out = tempfile::tempdir().unwrap();
    let options =
        RunOptions { targets: vec![], out_dir: out.path().into(), cache: None, jobs: None, observer: &Silent };
    match scheduler::run(&p, &options) {
        Ok(_) => panic!("the run should fail"),
        Err(e) => e.to_string(),
    }
}

fn validation_errors(text: &str) -> String {
    let registry = hdrflow::builtin_registry();
    Pipeline::parse(text, "t.ron", Path::new("."), &registry, &[]).expect_err("invalid pipeline").to_string()
}

#[test]
fn run_time_errors_name_what_the_image_has() {
    let e = run_error(
        r#"( nodes: { "env": LoadHdr(path: "builtin:constant"), "s": SplitChannels(image: "env"),
                      "m": MergeChannels(channels: ["s.R", "s.Z"]) } )"#,
    );
    assert!(e.contains("node \"s\" (SplitChannels): the image has no channel \"Z\" (its channels: R, G, B)"), "{e}");
    let e = run_error(
        r#"( nodes: { "env": LoadHdr(path: "builtin:constant"), "c": Crop(image: "env", x: 60, width: 8, height: 8) } )"#,
    );
    assert!(e.contains("the rectangle x 60..68, y 0..8 does not fit inside the 64x32 image"), "{e}");
    let e = run_error(
        r#"( nodes: { "a": LoadHdr(path: "builtin:constant"), "b": LoadHdr(path: "builtin:sky"),
                      "m": MergeChannels(channels: ["a", "b"]) } )"#,
    );
    assert!(e.contains("inputs must have the same size: channels[0] is 64x32, channels[1] is 512x256"), "{e}");
}

#[test]
fn validation_catches_what_it_can() {
    // Checks of each node's own fields (all reported at once).
    let e = validation_errors(
        r#"( nodes: { "env": LoadHdr(path: "builtin:sky"), "s": SplitChannels(image: "env"),
                      "m": MergeChannels(channels: ["s.R", "s.G"], names: ["R"]),
                      "x": Math(a: "env", b: "env", op: Add, value: 2),
                      "c": Crop(image: "env", width: 100000, height: 100000) } )"#,
    );
    assert!(e.contains("node \"m\": 1 names for 2 channels"), "{e}");
    assert!(e.contains("node \"x\": `value` is used only when `b` is not wired"), "{e}");
    assert!(e.contains("node \"c\": a 100000 x 100000 image exceeds the engine's limit"), "{e}");
    // SplitChannels has no default port.
    let e = validation_errors(
        r#"( nodes: { "env": LoadHdr(path: "builtin:sky"), "s": SplitChannels(image: "env"),
                      "d": Exposure(image: "s", stops: 1) } )"#,
    );
    assert!(e.contains("node \"s\" has no default output: name one of its ports, e.g. \"s.NAME\""), "{e}");
    // A type error on an open port names the port.
    let e = validation_errors(
        r#"( nodes: { "env": LoadHdr(path: "builtin:sky"), "s": SplitChannels(image: "env"),
                      "sh": ShIrradiance(env: "s.R") } )"#,
    );
    assert!(e.contains("but port \"s.R\" (SplitChannels) gives scalar field"), "{e}");
    // A merge of one scalar field is a scalar field, so it can feed BuildCdf.
    let registry = hdrflow::builtin_registry();
    Pipeline::parse(
        r#"( nodes: { "env": LoadHdr(path: "builtin:sky"), "s": SplitChannels(image: "env"),
                      "g": MergeChannels(channels: ["s.G"]), "cdf": BuildCdf(luminance: "g") } )"#,
        "t.ron",
        Path::new("."),
        &registry,
        &[],
    )
    .expect("a one-channel merge is a scalar field");
}

/// Channel names with dots (an EXR layer's `diffuse.R`) are addressable as ports: the longest
/// node name before a dot wins. And an open-port node caches every channel, so a second pipeline
/// naming another channel of the same image is served from the cache.
#[test]
fn dotted_channel_names_and_open_ports_in_the_cache() {
    let registry = hdrflow::builtin_registry();
    let text = |port: &str| {
        format!(
            r#"( nodes: {{ "env": LoadHdr(path: "builtin:sky"), "lum": Luminance(image: "env"),
                 "layer": MergeChannels(channels: ["lum", "lum"], names: ["diffuse.Y", "specular.Y"]),
                 "s": SplitChannels(image: "layer"), "x": Exposure(image: "s.{port}", stops: 1) }} )"#
        )
    };
    let dir = tempfile::tempdir().unwrap();
    let cache = hdrflow::engine::cache::CacheStore::new(dir.path().join("cache"), 1 << 30);
    let mut results = Vec::new();
    for port in ["diffuse.Y", "specular.Y"] {
        let p = Pipeline::parse(&text(port), "t.ron", Path::new("."), &registry, &[]).expect("a dotted port resolves");
        let options = RunOptions {
            targets: vec!["x".into()],
            out_dir: dir.path().join("out"),
            cache: Some(cache.clone()),
            jobs: None,
            observer: &Silent,
        };
        let outcome = scheduler::run(&p, &options).expect("runs");
        results.push((outcome.report.status_of("s"), image(&outcome.values, "x").data[17]));
    }
    assert_eq!(results[0].0, Some(scheduler::NodeStatus::Computed));
    assert_eq!(results[1].0, Some(scheduler::NodeStatus::Cached), "the second channel comes from the cache");
    assert_eq!(results[0].1, results[1].1, "both channels are the luminance");
    let e =
        validation_errors(&text("diffuse.Z").replace("SplitChannels(image: \"layer\")", "Luminance(image: \"layer\")"));
    assert!(e.contains("node \"s\" has no output port \"diffuse.Z\""), "{e}");
}

/// A `SplitChannels` node that is a target (no consumer names a port) returns every channel, as
/// `node.CHANNEL`, computed and from the cache alike.
#[test]
fn an_open_port_target_returns_every_channel() {
    let registry = hdrflow::builtin_registry();
    let text = r#"( nodes: { "env": Constant(width: 4, height: 2, color: (0.25, 0.5, 1.0)), "s": SplitChannels(image: "env") } )"#;
    let p = Pipeline::parse(text, "t.ron", Path::new("."), &registry, &[]).expect("valid");
    let dir = tempfile::tempdir().unwrap();
    let cache = hdrflow::engine::cache::CacheStore::new(dir.path().join("cache"), 1 << 30);
    for pass in ["computed", "cached"] {
        let options = RunOptions {
            targets: vec!["s".into()],
            out_dir: dir.path().join("out"),
            cache: Some(cache.clone()),
            jobs: None,
            observer: &Silent,
        };
        let outcome = scheduler::run(&p, &options).expect("runs");
        let names: Vec<&str> = outcome.values.keys().map(String::as_str).collect();
        assert_eq!(names, ["s.B", "s.G", "s.R"], "{pass}");
        assert_eq!(image(&outcome.values, "s.G").data, vec![0.5; 8], "{pass}");
    }
}
