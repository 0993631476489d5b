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

#[test]
fn custom_operator_example_runs_and_inverts() {
    let mut cmd = Command::new(env!("CARGO"));
    cmd.args(["run", "--quiet", "--example", "custom_operator"]).current_dir(env!("CARGO_MANIFEST_DIR"));
    // Run the example in the profile the tests were built with, so that nothing is rebuilt.
    let profile_dir = Path::new(env!("CARGO_BIN_EXE_hdrflow")).parent().and_then(|p| p.file_name());
    if profile_dir.is_some_and(|d| d == "release") {
        cmd.arg("--release");
    }
    cmd.env_remove("CARGO_TARGET_TMPDIR");
    let out = run_command(cmd, Duration::from_secs(600));
    out.assert_success().assert_stdout_contains("Invert(white: 2.0)");
    out.assert_stdout_contains("[1.75, 1.5, 1.0]");
}
