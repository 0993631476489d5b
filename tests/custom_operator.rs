//! The `examples/custom_operator.rs` example (an operator defined outside hdrflow, registered and
//! run from a pipeline) must keep working: it is the documented extension point.
//!
//! `cargo test` builds the examples, so this `cargo run` normally only runs the binary. Cargo
//! releases its build-folder lock before it runs test binaries, so the nested `cargo` does not wait
//! on the outer one; the timeout turns any such wait into a failure instead of a hang.

mod common;

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use common::run_command;

fn example(args: &[&str], dir: &Path) -> common::Output {
    let mut cmd = Command::new(env!("CARGO"));
    cmd.args(["run", "--quiet", "--example", "custom_operator"]).current_dir(env!("CARGO_MANIFEST_DIR"));
    // Run the example in the profile the tests were built with, so that nothing is rebuilt.
    let profile_dir = Path::new(env!("CARGO_BIN_EXE_hdrflow")).parent().and_then(|p| p.file_name());
    if profile_dir.is_some_and(|d| d == "release") {
        cmd.arg("--release");
    }
    cmd.arg("--").args(args);
    cmd.env_remove("CARGO_TARGET_TMPDIR");
    cmd.env("HDRFLOW_CACHE_DIR", dir.join("cache"));
    run_command(cmd, Duration::from_secs(600))
}

#[test]
fn custom_operator_example_is_a_full_cli() {
    let dir = tempfile::tempdir().unwrap();
    // `ops` lists the extra operator with its typed fields and port.
    let ops = example(&["ops", "Invert"], dir.path());
    ops.assert_success().assert_stdout_contains("Invert (v1)");
    ops.assert_stdout_contains("white");
    ops.assert_stdout_contains("-> image");

    // `run` with `--set` and the cache: a pipeline file that uses it.
    let out = dir.path().join("out");
    let out_s = out.display().to_string();
    let run = example(&["run", "examples/invert.ron", "--out", &out_s, "--set", "inv.white=3.0"], dir.path());
    run.assert_success();
    let image = hdrflow::formats::pfm::decode(&std::fs::read(out.join("inverted.pfm")).unwrap()).unwrap();
    assert_eq!(image.rgb(0, 0), [2.75, 2.5, 2.0], "Invert(white: 3.0) of (0.25, 0.5, 1.0)");

    // A second run comes from the cache.
    let report = dir.path().join("report.json");
    let report_s = report.display().to_string();
    example(
        &["run", "examples/invert.ron", "--out", &out_s, "--set", "inv.white=3.0", "--report", &report_s],
        dir.path(),
    )
    .assert_success();
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let computed: Vec<&str> = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n["status"] == "computed")
        .map(|n| n["name"].as_str().unwrap())
        .collect();
    assert!(computed.is_empty(), "a cached rerun computed {computed:?}");

    // Pipeline errors keep their positions through the library CLI.
    let bad = example(&["run", "examples/invert.ron", "--set", "inv.whit=1"], dir.path());
    assert_eq!(bad.code, Some(2));
    bad.assert_stderr_contains("did you mean \"white\"");
}
