//! `bench/peers/evaluation_speed.sh`, the book's comparison of the whole example evaluation with
//! the Blender protocol, runs end to end: at 10% and 1 sample (Blender's part small), it prepares
//! the six maps, renders their 18 spheres in Blender, runs the example's batch twice, and prints
//! its three lines; the batch scored the three pairs. Times are not checked (they belong to the
//! benchmark page). Without Blender the test skips visibly, and fails under
//! `HDRFLOW_REQUIRE_BLENDER=1`.

mod common;

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use common::{run_command, Sandbox, BIN, MANIFEST_DIR};

#[test]
fn the_evaluation_speed_script_runs_blender_and_the_batch_and_prints_both_ratios() {
    let blender = std::env::var_os("PATH")
        .and_then(|paths| std::env::split_paths(&paths).map(|p| p.join("blender")).find(|p| p.is_file()));
    if blender.is_none() {
        common::skip("HDRFLOW_REQUIRE_BLENDER", "blender is not on PATH (Debian: apt-get install blender)");
        return;
    }
    let sandbox = Sandbox::new();
    let out = sandbox.path().join("speed");
    let mut cmd = Command::new("bash");
    cmd.arg(Path::new(MANIFEST_DIR).join("bench/peers/evaluation_speed.sh"))
        .args([out.to_str().expect("a UTF-8 temporary path"), "10", "1"])
        .env("HDRFLOW", BIN)
        .current_dir(MANIFEST_DIR);
    let output = run_command(cmd, Duration::from_secs(900));
    assert_eq!(output.code, Some(0), "the script failed: {}", output.describe());
    let (stdout, stderr) = (&output.stdout, &output.stderr);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(lines[0].starts_with("Blender, 18 spheres at 10% and 1 samples: "), "{stdout}");
    assert!(lines[1].starts_with("hdrflow, the batch of 3 pairs (18 spheres, empty cache): "), "{stdout}");
    assert!(lines[2].starts_with("hdrflow, one pair alone: "), "{stdout}");
    assert!(stderr.contains("Blender renders 10%"), "the script says its frames differ: {stderr}");
    // Blender wrote each map's three spheres; the batch scored each pair's three.
    let spheres = std::fs::read_dir(out.join("prepared"))
        .expect("the prepared maps' folder")
        .flatten()
        .map(|e| std::fs::read_dir(e.path().join("blender/seed0")).map(|d| d.count()).unwrap_or(0))
        .sum::<usize>();
    assert_eq!(spheres, 18);
    let metrics = std::fs::read_to_string(out.join("all/metrics.csv")).expect("the batch's metrics.csv");
    assert_eq!(metrics.lines().count(), 1 + 9, "{metrics}");
}
