//! The capture operators against OpenCV's photo module on the same frames, in the same run
//! (`bench/peers/capture_opencv.py`, run with the peer Python of `scripts/peer-venv.sh`; skips
//! visibly without it): five 8-bit sRGB PNG brackets two stops apart of a CC0 map, made and
//! saved by hdrflow (EXIF times), merged by `CalibrateResponse` + `MergeBrackets` and by
//! `CalibrateDebevec` + `MergeDebevec`, both measured by the script's one error measure against
//! the map; then shifted frames, whose `AlignBrackets(pairing: Reference)` shifts must equal
//! `AlignMTB`'s.

mod common;

use std::path::Path;

use common::*;
use serde_json::Value as Json;

const MAP: &str = "assets/maps/st_fagans_interior_1k.hdr";

fn make_frames(sb: &Sandbox, times: &str, shifts: &str) {
    make_frames_with(sb, times, shifts, "response: Srgb");
}

/// `make_frames` with other `SimulateBrackets` fields (a response, noise).
fn make_frames_with(sb: &Sandbox, times: &str, shifts: &str, camera: &str) {
    let path = ron_path(&Path::new(MANIFEST_DIR).join(MAP));
    let graph = sb.write(
        "make.ron",
        format!(
            r#"(nodes: {{
    "env":   LoadHdr(path: {path}),
    "sim":   SimulateBrackets(env: "env", times: [{times}], {camera}, scale: 100, shifts: [{shifts}]),
    "shots": Save(input: "sim", path: "frames/shot_{{frame}}.png"),
    "truth": Save(input: "env", path: "truth.pfm"),
}})"#
        ),
    );
    sb.run_ok(&graph, &[]);
}

fn opencv(python: &Path, sb: &Sandbox, extra: &[&str]) -> Json {
    let mut cmd = std::process::Command::new(python);
    cmd.arg(Path::new(MANIFEST_DIR).join("bench/peers/capture_opencv.py"));
    cmd.arg(sb.out().join("frames")).arg("--out-dir").arg(sb.join("opencv"));
    cmd.args(["--format", "pfm", "--repeats", "0", "--no-cut"]).args(extra);
    let out = run_command(cmd, std::time::Duration::from_secs(300));
    out.assert_success();
    serde_json::from_str(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", out.stdout))
}

#[test]
fn the_merge_is_at_least_as_exact_as_opencv_on_the_same_frames() {
    let Some(python) = peer_python() else { return };
    let sb = Sandbox::new();
    make_frames(&sb, "0.00025, 0.001, 0.004, 0.016, 0.064", "");
    merge_against_opencv(&python, &sb);
}

/// The same through a film-like S curve with shot and read noise (a 32768-electron full well, 4
/// electrons of read noise): measured 2.8% against OpenCV's 4.1% (docs/src/benchmarks/capture.md).
#[test]
fn the_merge_of_noisy_frames_is_at_least_as_exact_as_opencv() {
    let Some(python) = peer_python() else { return };
    let sb = Sandbox::new();
    make_frames_with(&sb, "0.00025, 0.001, 0.004, 0.016, 0.064", "", "response: SCurve, noise: 1");
    merge_against_opencv(&python, &sb);
}

/// Merges the sandbox's frames with hdrflow and OpenCV (Debevec's calibration for both) and
/// requires hdrflow's median error against the map to be at most OpenCV's and under 3%.
fn merge_against_opencv(python: &Path, sb: &Sandbox) {
    let graph = sb.write(
        "merge.ron",
        r#"(nodes: {
    "b":      LoadBrackets(paths: "out/frames/"),
    "resp":   CalibrateResponse(brackets: "b"),
    "merged": MergeBrackets(brackets: "b", response: "resp"),
    "save":   Save(input: "merged", path: "merged.pfm"),
})"#,
    );
    sb.run_ok(&graph, &[]);
    let truth = sb.out().join("truth.pfm").display().to_string();
    let ours = format!("hdrflow={}", sb.out().join("merged.pfm").display());
    let r = opencv(python, sb, &["--no-align", "--truth", &truth, "--also", &ours]);
    let theirs = r["merge_error_debevec"]["median_rel"].as_f64().unwrap();
    let mine = r["also"]["hdrflow"]["merge_error"]["median_rel"].as_f64().unwrap();
    assert_eq!(r["also"]["hdrflow"]["nonfinite"].as_u64(), Some(0));
    assert!(mine <= theirs, "hdrflow's merge is {mine:.5} off the map, OpenCV's {theirs:.5}: {r}");
    assert!(mine < 0.03, "hdrflow's merge is {mine:.5} off the map (the issue's bound: 3%)");
}

/// The shifts that undo `make_frames`' shake (3, -2), (1, 0), (0, 0), (-2, 1), (4, 3).
const TRUE_SHIFTS: [[f64; 2]; 5] = [[-3.0, 2.0], [-1.0, 0.0], [0.0, 0.0], [2.0, -1.0], [-4.0, -3.0]];

#[test]
fn align_brackets_finds_align_mtbs_shifts() {
    let Some(python) = peer_python() else { return };
    let sb = Sandbox::new();
    // One stop apart: Ward's bitmaps of frames four stops apart share too little (OpenCV's
    // AlignMTB and the Reference pairing both return noise for the longest frame against the
    // middle one at two stops per frame; the default Chained pairing does not compare them).
    make_frames(&sb, "0.001, 0.002, 0.004, 0.008, 0.016", "3, -2, 1, 0, 0, 0, -2, 1, 4, 3");
    let graph = sb.write(
        "align.ron",
        r#"(nodes: {
    "b":     LoadBrackets(paths: "out/frames/"),
    "a":     AlignBrackets(brackets: "b", pairing: Reference),
    "save":  Save(input: "a.shifts", path: "shifts.json"),
})"#,
    );
    sb.run_ok(&graph, &[]);
    let ours: Json = serde_json::from_slice(&read_file(&sb.out().join("shifts.json"))).unwrap();
    let r = opencv(&python, &sb, &[]);
    let shifts = r["shifts"].as_object().expect("the script's shifts");
    let mut names: Vec<&String> = shifts.keys().collect();
    names.sort();
    for (k, name) in names.iter().enumerate() {
        let theirs: Vec<f64> = shifts[*name].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let mine = [ours[format!("dx_{k}")].as_f64().unwrap(), ours[format!("dy_{k}")].as_f64().unwrap()];
        assert_eq!(mine.to_vec(), theirs, "frame {name}: hdrflow {mine:?}, AlignMTB {theirs:?}");
        // And both undo the shake the frames were made with.
        assert_eq!(mine, TRUE_SHIFTS[k], "frame {name}");
    }
}
