//! The capture helpers of issue 38 that need no bracket loader, end to end through the CLI with
//! RON pipelines: `CalibrateIlluminance` (a constant map scaled to exactly lux / pi, its metrics),
//! `MergeMirrorBalls` (two balls rendered by `LatLongToMirrorBall` from a smooth map merge back
//! to it, the blind spot behind each ball filled by the other), and the bad inputs of
//! `AlignBrackets`, `CalibrateIlluminance` and `MergeMirrorBalls` as validation errors naming
//! the field (exit code 2, nothing run). `AlignBrackets` itself is tested in
//! `maths::capture::align` (no operator on this branch makes a bracket from files).

mod common;

use std::f64::consts::PI;

use common::Sandbox;
use glam::DVec3;
use hdrflow::geometry::latlong;
use hdrflow::values::Image;

/// A smooth RGB lat-long map: 2 + d.y + 0.5 d.x - 0.3 d.z^2 (per channel scaled).
fn smooth(w: usize, h: usize) -> Image {
    Image::from_fn_rgb(w, h, |x, y| {
        let d = DVec3::from(latlong::texel_direction(x, y, w, h));
        let v = 2.0 + d.y + 0.5 * d.x - 0.3 * d.z * d.z;
        [v as f32, (0.8 * v) as f32, (1.2 * v) as f32]
    })
}

fn save_pfm(sb: &Sandbox, name: &str, img: &Image) -> String {
    common::ron_path(&sb.write(name, hdrflow::formats::pfm::encode(img)))
}

fn load_pfm(sb: &Sandbox, name: &str) -> Image {
    hdrflow::formats::pfm::decode(&common::read_file(&sb.out().join(name))).unwrap()
}

#[test]
fn a_constant_map_is_calibrated_to_exactly_lux_over_pi() {
    let sb = Sandbox::new();
    let env = Image::from_fn_rgb(64, 32, |_, _| [1.5, 1.5, 1.5]);
    let graph = sb.write(
        "g.ron",
        format!(
            r#"(nodes: {{
            "env": LoadHdr(path: {}),
            "cal": CalibrateIlluminance(env: "env", lux: 1000),
            "s1": Save(input: "cal", path: "cal.pfm"),
            "s2": Save(input: "cal.metrics", path: "cal.json"),
        }})"#,
            save_pfm(&sb, "env.pfm", &env)
        ),
    );
    sb.run_ok(&graph, &[]);
    let out = load_pfm(&sb, "cal.pfm");
    let want = 1000.0 / PI;
    for v in &out.data {
        assert!(((*v as f64) / want - 1.0).abs() < 1e-6, "{v} vs {want}");
    }
    let metrics: serde_json::Value = serde_json::from_slice(&common::read_file(&sb.out().join("cal.json"))).unwrap();
    let get = |k: &str| metrics[k].as_f64().unwrap_or_else(|| panic!("no {k} in {metrics}"));
    assert!((get("illuminance_before") / (1.5 * PI) - 1.0).abs() < 1e-12, "{metrics}");
    assert!((get("illuminance_after") / 1000.0 - 1.0).abs() < 1e-6, "{metrics}");
    assert!((get("scale") * 1.5 * PI / 1000.0 - 1.0).abs() < 1e-6, "{metrics}");
}

#[test]
fn two_rendered_mirror_balls_merge_back_to_their_map() {
    let sb = Sandbox::new();
    let env = smooth(512, 256);
    let graph = sb.write(
        "g.ron",
        format!(
            r#"(nodes: {{
            "env": LoadHdr(path: {}),
            "a": LatLongToMirrorBall(env: "env", size: 256, yaw: 0),
            "b": LatLongToMirrorBall(env: "env", size: 256, yaw: 90),
            "m": MergeMirrorBalls(a: "a", b: "b", view_a: (0, 0), view_b: (90, 0), width: 128),
            "d": MergeMirrorBalls(a: "a", b: "b", view_a: (0, 0), view_b: (90, 0)),
            "s1": Save(input: "m", path: "m.pfm"),
            "s2": Save(input: "m.mask", path: "mask.pfm"),
            "s3": Save(input: "d", path: "default.pfm"),
        }})"#,
            save_pfm(&sb, "env.pfm", &env)
        ),
    );
    sb.run_ok(&graph, &[]);
    let merged = load_pfm(&sb, "m.pfm");
    let mask = load_pfm(&sb, "mask.pfm");
    assert_eq!((merged.width, merged.height), (128, 64));
    assert!(mask.data.iter().all(|&m| m == 0.0), "two views 90 degrees apart see every direction");
    let want = smooth(128, 64);
    let worst = merged.data.iter().zip(&want.data).map(|(g, w)| ((g - w) / w).abs()).fold(0.0f32, f32::max);
    assert!(worst < 1e-2, "worst relative error {worst}");
    // Behind ball a (its camera looks along -Z) only ball b sees: the value is still right.
    let (x, y) = latlong::texel_of_direction([0.0, 0.0, -1.0], 128, 64);
    assert!((merged.pixel(x, y)[0] / want.pixel(x, y)[0] - 1.0).abs() < 1e-2);
    // The default size is twice the ball's diameter: 512 x 256.
    let d = load_pfm(&sb, "default.pfm");
    assert_eq!((d.width, d.height), (512, 256));
}

/// Runs a one-node pipeline (plus a map) that must fail validation: exit code 2, `needles` in
/// stderr, nothing written.
fn refused(node: &str, needles: &[&str]) {
    let sb = Sandbox::new();
    let env = Image::from_fn_rgb(8, 4, |_, _| [1.0; 3]);
    let ball = Image::from_fn_rgb(8, 8, |_, _| [1.0; 3]);
    let graph = sb.write(
        "g.ron",
        format!(
            r#"(nodes: {{
            "env": LoadHdr(path: {}),
            "ball": LoadHdr(path: {}),
            "x": {node},
            "s": Save(input: "x", path: "x.pfm"),
        }})"#,
            save_pfm(&sb, "env.pfm", &env),
            save_pfm(&sb, "ball.pfm", &ball)
        ),
    );
    let (out, _) = sb.run(&graph, &[]);
    out.assert_code(2);
    for n in needles {
        out.assert_stderr_contains(n);
    }
    assert!(!sb.out().join("x.pfm").exists(), "nothing runs");
}

#[test]
fn bad_fields_are_validation_errors_naming_the_field() {
    refused(r#"CalibrateIlluminance(env: "env", lux: 0)"#, &["lux", "positive"]);
    refused(r#"CalibrateIlluminance(env: "env", lux: -3.5)"#, &["lux", "positive"]);
    let balls = |f: &str| {
        format!(r#"MergeMirrorBalls(a: "ball", b: "ball", view_a: (0, 0), view_b: (90, 0), ball_fraction: {f})"#)
    };
    refused(&balls("0"), &["ball_fraction"]);
    refused(&balls("1.5"), &["ball_fraction"]);
    refused(r#"MergeMirrorBalls(a: "env", b: "ball", view_a: (0, 0), view_b: (90, 0))"#, &["\"a\" is 8x4", "square"]);
    // No operator on this branch makes a bracket: the wrong input type is reported with the
    // max_shift range, every problem at once.
    refused(r#"AlignBrackets(brackets: "env", max_shift: 0)"#, &["max_shift"]);
    refused(r#"AlignBrackets(brackets: "env", max_shift: 1000000)"#, &["max_shift"]);
}
