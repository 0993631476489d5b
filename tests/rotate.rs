//! `Rotate` in pipelines: a whole-column yaw is an exact roll of the columns, any rotation keeps
//! the sphere integral, a cube map rotates like its lat-long map, and bad rotations are pipeline
//! errors with the field's position before anything runs.

mod common;

use hdrflow::maths::resample::layouts::{cube_integral, latlong_integral};
use hdrflow::values::{Cubemap, Image};

#[test]
fn a_quarter_turn_rolls_the_columns_and_any_turn_keeps_the_integral() {
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "yaw": Rotate(image: "env", yaw: 90),
        "any": Rotate(image: "env", yaw: 12.5, pitch: -30, roll: 7),
        "cube": LatLongToCubemap(image: "env", size: 32),
        "cube_any": Rotate(image: "cube", yaw: 12.5, pitch: -30, roll: 7),
    })"#;
    let v = common::run_text(text, &["env", "yaw", "any", "cube", "cube_any"]).expect("runs");
    let env = v["env"].get::<Image>().unwrap();
    let yaw = v["yaw"].get::<Image>().unwrap();
    let (w, h) = (env.width, env.height);
    let k = w / 4;
    for y in 0..h {
        for x in 0..w {
            assert_eq!(yaw.pixel(x, y), env.pixel((x + k) % w, y), "({x}, {y})");
        }
    }
    let (a, b) = (latlong_integral(env), latlong_integral(v["any"].get::<Image>().unwrap()));
    for c in 0..3 {
        assert!(((b[c] - a[c]) / a[c]).abs() < 1e-4, "channel {c}: {} vs {}", b[c], a[c]);
    }
    let (a, b) =
        (cube_integral(v["cube"].get::<Cubemap>().unwrap()), cube_integral(v["cube_any"].get::<Cubemap>().unwrap()));
    for c in 0..3 {
        assert!(((b[c] - a[c]) / a[c]).abs() < 1e-4, "cube channel {c}: {} vs {}", b[c], a[c]);
    }
}

#[test]
fn bad_rotations_are_pipeline_errors_with_positions() {
    let skew = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "r": Rotate(image: "env", matrix: (1, 0.001, 0, 0, 1, 0, 0, 0, 1)),
    })"#;
    let e = common::run_text(skew, &["r"]).unwrap_err();
    assert!(e.contains("3:") && e.contains("\"r\"") && e.contains("not orthonormal"), "{e}");
    let mirror = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "r": Rotate(image: "env", matrix: (-1, 0, 0, 0, 1, 0, 0, 0, 1)),
    })"#;
    let e = common::run_text(mirror, &["r"]).unwrap_err();
    assert!(e.contains("a mirror, not a rotation"), "{e}");
    let both = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "r": Rotate(image: "env", yaw: 10, matrix: (1, 0, 0, 0, 1, 0, 0, 0, 1)),
    })"#;
    let e = common::run_text(both, &["r"]).unwrap_err();
    assert!(e.contains("either yaw/pitch/roll or a matrix"), "{e}");
    let wrong_type = r#"(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "lum": Luminance(image: "env"),
        "cdf": BuildCdf(luminance: "lum"),
        "r": Rotate(image: "cdf", yaw: 10),
    })"#;
    let e = common::run_text(wrong_type, &["r"]).unwrap_err();
    assert!(e.contains("\"r\"") && e.contains("distribution"), "{e}");
}
