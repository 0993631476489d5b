//! `Project` and `Embed` (issue 26) end to end, through real RON pipelines: the worked example
//! `graphs/camera_views.ron` on the park, closed forms on `builtin:linear`, agreement with
//! `Rotate`'s convention, `Embed(Project(env))`, and every bad field as a positioned pipeline
//! error naming its node.

mod common;

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::engine::value::Value;
use hdrflow::geometry::latlong;
use hdrflow::geometry::lens::{Lens, Model};
use hdrflow::values::Image;

fn run(text: &str, targets: &[&str]) -> Result<BTreeMap<String, Value>, String> {
    common::run_text(text, targets)
}

fn image<'a>(v: &'a BTreeMap<String, Value>, name: &str) -> &'a Image {
    v.get(name).unwrap_or_else(|| panic!("no value {name:?}")).get::<Image>().expect("an image")
}

/// The solid-angle-weighted mean of channel `k` of a view through `lens`.
fn view_mean(view: &Image, lens: &Lens, k: usize) -> f64 {
    let (mut sum, mut total) = (0.0, 0.0);
    for j in 0..view.height {
        for i in 0..view.width {
            let (x0, y0) = lens.plane(i as f64, j as f64 + 1.0);
            let (x1, y1) = lens.plane(i as f64 + 1.0, j as f64);
            let omega = lens.rect_solid_angle(x0, x1, y0, y1);
            sum += omega * view.pixel(i, j)[k] as f64;
            total += omega;
        }
    }
    sum / total
}

/// `1 + (0.3, 0.5, 0.2).d`: `builtin:linear`'s radiance.
fn linear(d: [f64; 3]) -> f64 {
    1.0 + 0.3 * d[0] + 0.5 * d[1] + 0.2 * d[2]
}

#[test]
fn the_worked_example_runs_and_its_views_agree() {
    let graph = concat!(env!("CARGO_MANIFEST_DIR"), "/graphs/camera_views.ron");
    let registry = hdrflow::builtin_registry();
    let p = hdrflow::Pipeline::load(Path::new(graph), &registry, &[]).expect("graphs/camera_views.ron is valid");
    let out = tempfile::tempdir().unwrap();
    let options = RunOptions {
        targets: p.nodes.iter().map(|n| n.name.clone()).collect(),
        out_dir: out.path().into(),
        cache: None,
        jobs: None,
        observer: &Silent,
    };
    let v = scheduler::run(&p, &options).expect("graphs/camera_views.ron runs").values;
    let env = image(&v, "env");
    let lens = Lens::new(Model::Perspective, 60.0, 512, 512).unwrap();
    for name in ["front", "left", "back", "right", "front_area", "sky"] {
        let view = image(&v, name);
        assert_eq!((view.width, view.height, view.channels), (512, 512, 3), "{name}");
        assert!(view.data.iter().all(|x| x.is_finite() && *x >= 0.0), "{name}");
    }
    for file in ["front", "left", "back", "right", "front_area", "sky_fisheye", "pasted", "pasted_mask"] {
        assert!(out.path().join(format!("{file}.exr")).is_file(), "{file}.exr");
    }
    // The two filters see the same light: the front crop's means agree to 2e-4 (measured 2e-5).
    for k in 0..3 {
        let (b, a) = (view_mean(image(&v, "front"), &lens, k), view_mean(image(&v, "front_area"), &lens, k));
        assert!((a - b).abs() < 2e-4 * a, "channel {k}: area {a} vs bilinear {b}");
    }
    // The fisheye is black outside its circle and sees the sky inside.
    let sky = image(&v, "sky");
    assert_eq!(sky.pixel(0, 0), [0.0; 3]);
    assert!(sky.pixel(256, 256).iter().all(|&x| x > 0.0));
    // The mask covers the frustum, 4 asin(sin^2 30 deg) sr, to its texel quantisation (1%);
    // inside it, the pasted map is the park to the two lookups' error (mean relative error 2%;
    // measured 0.56%: the sun's edge and the trees are sharp at 1k).
    let (pasted, mask) = (image(&v, "pasted"), image(&v, "pasted.mask"));
    assert_eq!((mask.width, mask.height, mask.channels), (1024, 512, 1));
    let (mut covered, mut err, mut sum) = (0.0, 0.0, 0.0);
    for y in 0..512 {
        for x in 0..1024 {
            let m = mask.pixel(x, y)[0];
            assert!(m == 0.0 || m == 1.0);
            if m == 1.0 {
                covered += latlong::texel_solid_angle(y, 1024, 512);
                for k in 0..3 {
                    err += (pasted.pixel(x, y)[k] - env.pixel(x, y)[k]).abs() as f64;
                    sum += env.pixel(x, y)[k] as f64;
                }
            } else {
                assert_eq!(pasted.pixel(x, y), [0.0; 3]);
            }
        }
    }
    let frustum = 4.0 * (0.25f64).asin();
    assert!((covered - frustum).abs() < 1e-2 * frustum, "{covered} vs {frustum}");
    assert!(err / sum < 0.02, "mean relative round-trip error {}", err / sum);
}

#[test]
fn the_documented_example_is_a_valid_pipeline() {
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/src/guides/toolkit/camera.md")).unwrap();
    let start = doc.find("```ron\n").expect("docs/src/guides/toolkit/camera.md has a RON example") + "```ron\n".len();
    let text = &doc[start..start + doc[start..].find("```").unwrap()];
    let registry = hdrflow::builtin_registry();
    let graphs = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/graphs"));
    let p = hdrflow::Pipeline::parse(text, "camera.md", graphs, &registry, &[]).map_err(|e| e.to_string());
    assert_eq!(p.expect("the example parses and validates").nodes.len(), 10);
}

#[test]
fn the_centre_pixel_sees_the_direction_rotate_predicts() {
    // builtin:linear is 1 + b.d; the centre pixel of an odd view looks along R (-Z).
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:linear"),
        "left": Project(env: "env", width: 33, height: 33, fov: 60, yaw: 90),
        "right": Project(env: "env", width: 33, height: 33, fov: 60, yaw: -90, filter: Area),
        "up": Project(env: "env", width: 33, height: 33, fov: 60, pitch: 45, model: Fisheye),
        "rolled": Project(env: "env", width: 33, height: 33, fov: 60, pitch: 45, roll: 30, model: Orthographic),
    })"#;
    let v = run(text, &["left", "right", "up", "rolled"]).expect("runs");
    let s = 0.5f64.sqrt();
    for (name, d) in
        [("left", [-1.0, 0.0, 0.0]), ("right", [1.0, 0.0, 0.0]), ("up", [0.0, s, -s]), ("rolled", [0.0, s, -s])]
    {
        let got = image(&v, name).pixel(16, 16)[0] as f64;
        assert!((got - linear(d)).abs() < 1e-3, "{name}: {got} vs {}", linear(d));
    }
}

#[test]
fn projecting_a_rotated_map_is_projecting_with_the_inverse_rotation() {
    // Project(Rotate(env, R), Q) sees env along R^T Q c: Rotate(yaw 90) then pitch 10 is
    // Project(yaw -90, pitch 10). A quarter turn is an exact roll of the columns, so both
    // filters give the same lookups (measured: equal bit for bit); a pitch is resampled, so
    // they agree to its smoothing (measured 1.7e-3 relative).
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "turned": Rotate(image: "env", yaw: 90),
        "a": Project(env: "turned", width: 64, height: 48, fov: 75, pitch: 10),
        "b": Project(env: "env", width: 64, height: 48, fov: 75, yaw: -90, pitch: 10),
        "a_area": Project(env: "turned", width: 64, height: 48, fov: 75, pitch: 10, filter: Area),
        "b_area": Project(env: "env", width: 64, height: 48, fov: 75, yaw: -90, pitch: 10, filter: Area),
        "lin": LoadHdr(path: "builtin:linear"),
        "tilted": Rotate(image: "lin", pitch: 20),
        "c": Project(env: "tilted", width: 64, height: 48, fov: 75),
        "d": Project(env: "lin", width: 64, height: 48, fov: 75, pitch: -20),
    })"#;
    let v = run(text, &["a", "b", "a_area", "b_area", "c", "d"]).expect("runs");
    for (x, y, tol) in [("a", "b", 1e-6), ("a_area", "b_area", 1e-6), ("c", "d", 5e-3)] {
        let (x_img, y_img) = (image(&v, x), image(&v, y));
        let worst = x_img
            .data
            .iter()
            .zip(&y_img.data)
            .map(|(p, q)| ((p - q).abs() / q.abs().max(1e-3)) as f64)
            .fold(0.0, f64::max);
        assert!(worst < tol, "{x} vs {y}: worst relative difference {worst}");
    }
}

#[test]
fn embed_pastes_into_env_and_keeps_the_rest() {
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:linear"),
        "view": Project(env: "env", width: 200, height: 150, fov: 200, yaw: 30, model: Fisheye),
        "black": Math(a: "env", op: Mul, value: 0),
        "back": Embed(env: "black", view: "view", fov: 200, yaw: 30, model: Fisheye),
        "blank": Embed(view: "view", fov: 200, yaw: 30, model: Fisheye),
    })"#;
    let v = run(text, &["env", "back", "back.mask", "blank"]).expect("runs");
    let (env, back, mask) = (image(&v, "env"), image(&v, "back"), image(&v, "back.mask"));
    assert_eq!((image(&v, "blank").width, image(&v, "blank").height), (1024, 512));
    let (w, h) = (env.width, env.height);
    let mut covered = 0.0;
    for y in 0..h {
        for x in 0..w {
            if mask.pixel(x, y)[0] == 1.0 {
                covered += latlong::texel_solid_angle(y, w, h);
                let (a, b) = (back.pixel(x, y)[0], env.pixel(x, y)[0]);
                // Two bilinear lookups of a linear function, and half a pixel at the circle
                // (measured: 3.8e-3 at worst).
                assert!((a - b).abs() < 0.01, "({x}, {y}): {a} vs {b}");
            } else {
                assert_eq!(back.pixel(x, y), [0.0; 3], "({x}, {y}) keeps env (black)");
            }
        }
    }
    // The circle's cap, cut at the frame's top and bottom (150/200 of the width): between the
    // cap of the inscribed height's angle and the whole 100-degree cap.
    let cap = |deg: f64| 2.0 * PI * (1.0 - deg.to_radians().cos());
    assert!(covered < cap(100.0) && covered > cap(75.0), "{covered}");
}

#[test]
fn bad_fields_are_pipeline_errors_with_positions() {
    for (model, fov, range) in [
        ("Perspective", "180", "(0, 180)"),
        ("Perspective", "0", "(0, 180)"),
        ("Fisheye", "361", "(0, 360]"),
        ("Orthographic", "180.5", "(0, 180]"),
    ] {
        for op in ["Project(env: \"env\"", "Embed(view: \"env\""] {
            let text = format!(
                "(nodes: {{\n    \"env\": LoadHdr(path: \"builtin:sky\"),\n    \"cam\": {op}, fov: {fov}, model: {model}),\n}})"
            );
            let e = run(&text, &["cam"]).unwrap_err();
            assert!(e.contains("3:") && e.contains("\"cam\"") && e.contains("fov") && e.contains(range), "{e}");
            assert!(e.contains(model), "{e}");
        }
    }
    let both = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "cam": Embed(env: "env", view: "env", width: 64),
    })"#;
    let e = run(both, &["cam"]).unwrap_err();
    assert!(e.contains("\"cam\"") && e.contains("width") && e.contains("blank map"), "{e}");
    let kinds = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "lum": Luminance(image: "env"),
        "cam": Embed(env: "env", view: "lum"),
    })"#;
    let e = run(kinds, &["cam"]).unwrap_err();
    assert!(e.contains("\"cam\"") && e.contains("view is a"), "{e}");
    let channels = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "split": SplitChannels(image: "env"),
        "two": MergeChannels(channels: ["split.R", "split.G"]),
        "cam": Embed(env: "env", view: "two"),
    })"#;
    let e = run(channels, &["cam"]).unwrap_err();
    assert!(e.contains("\"cam\"") && e.contains("view has 2 channels") && e.contains("env has 3"), "{e}");
}
