//! `bench/peers/evaluation_speed.sh`, the book's comparison of the whole example evaluation with
//! the Blender protocol, runs end to end: at 10% and 1 sample (Blender's part small), in two
//! rounds (`REPEATS=2`, medians), it prepares the six maps, renders their 18 spheres in Blender,
//! runs the example's batches, and prints its lines; the batch scored the three pairs, and the next checkpoint read the truths' spheres
//! back. Times are not checked (they belong to the
//! benchmark page). Its `PROTOCOL_DIR` branch (the protocol's own scripts, from a checkout the
//! CI does not have) runs on a stand-in checkout whose three scripts copy each map to where the
//! real ones write its render, after checking that the copy of `utils.py` they import was
//! switched to the CPU and no denoiser: the plumbing (copy, patch, one process a material,
//! every render present, the fourth line) is what is tested. Without Blender the test skips
//! visibly, and fails under `HDRFLOW_REQUIRE_BLENDER=1`.

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
    let checkout = sandbox.path().join("protocol");
    stand_in_checkout(&checkout);
    let out = sandbox.path().join("speed");
    let mut cmd = Command::new("bash");
    cmd.arg(Path::new(MANIFEST_DIR).join("bench/peers/evaluation_speed.sh"))
        .args([out.to_str().expect("a UTF-8 temporary path"), "10", "1"])
        .env("HDRFLOW", BIN)
        .env("PROTOCOL_DIR", &checkout)
        .env("REPEATS", "2")
        .current_dir(MANIFEST_DIR);
    let output = run_command(cmd, Duration::from_secs(900));
    assert_eq!(output.code, Some(0), "the script failed: {}", output.describe());
    let (stdout, stderr) = (&output.stdout, &output.stderr);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 5, "{stdout}");
    assert!(
        lines[0].starts_with(
            "Blender, the protocol's scene (blender_protocol_scene.py), 18 spheres at 10% and 1 samples: "
        ),
        "{stdout}"
    );
    assert!(lines[1].starts_with("hdrflow, the batch of 3 pairs (18 spheres, empty cache): "), "{stdout}");
    assert!(lines[2].starts_with("hdrflow, one pair alone: "), "{stdout}");
    assert!(
        lines[3].starts_with("hdrflow, the blurred checkpoint against the same truths (their spheres cached): "),
        "{stdout}"
    );
    assert!(
        lines[4].starts_with("Blender, the protocol's own three scripts, 18 spheres at 10% and 1 samples: "),
        "{stdout}"
    );
    assert!(stderr.contains("Blender renders 10%"), "the script says its frames differ: {stderr}");
    // Two rounds, each measurement's median reported with every round's time.
    assert!(stderr.contains("medians of 2 rounds; each round's CPU seconds: Blender's scene "), "{stderr}");
    assert!(out.join("all-2/metrics.csv").is_file() && out.join("next-2/batch.json").is_file());
    // Each material's script saw the six maps, under the names the real scripts give them; the
    // checkout itself was left as it was.
    for material in ["mirror", "matte_silver", "diffuse"] {
        let mut names: Vec<String> = std::fs::read_dir(out.join("protocol-renders").join(material))
            .expect("a material's renders")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names.len(), 6, "{material}: {names:?}");
        assert!(names.iter().all(|n| !n.contains('-')), "{names:?}");
    }
    let utils = std::fs::read_to_string(checkout.join("stylelight/utils/utils.py")).expect("the stand-in's utils.py");
    assert!(utils.contains("use_denoising: bool = True"), "the checkout was changed");
    // Blender wrote each map's three spheres; the batch scored each pair's three.
    let spheres = std::fs::read_dir(out.join("prepared"))
        .expect("the prepared maps' folder")
        .flatten()
        .map(|e| std::fs::read_dir(e.path().join("blender/seed0")).map(|d| d.count()).unwrap_or(0))
        .sum::<usize>();
    assert_eq!(spheres, 18);
    let metrics = std::fs::read_to_string(out.join("all/metrics.csv")).expect("the batch's metrics.csv");
    assert_eq!(metrics.lines().count(), 1 + 9, "{metrics}");
    // The next checkpoint read the truths' spheres back from the cache: each item evaluated at
    // most 21 - 3 of the graph's nodes (the empty-cache batch, all 21).
    let evaluations = |name: &str| -> Vec<u64> {
        let report = std::fs::read_to_string(out.join(name).join("batch.json")).expect("a batch report");
        let rows: serde_json::Value = serde_json::from_str(&report).expect("the report is JSON");
        rows.as_array().expect("a row per item").iter().filter_map(|r| r["evaluations"].as_u64()).collect()
    };
    assert_eq!(evaluations("all"), vec![21; 3]);
    let next = evaluations("next");
    assert!(next.len() == 3 && next.iter().all(|&n| n <= 18), "the truths' spheres were not read back: {next:?}");
}

/// A stand-in for a DiffusionLight-evaluation checkout: `stylelight/utils/utils.py` with the two
/// defaults the script turns off, and three scripts taking the real ones' arguments (`--
/// PERCENT SAMPLES HDR_DIR SAVE_DIR START END`) that fail unless those defaults were turned off
/// and copy each `exr` map of HDR_DIR[START:END] to `SAVE_DIR/MATERIAL/<name up to its first '-'>`.
fn stand_in_checkout(dir: &Path) {
    let scripts = dir.join("stylelight");
    std::fs::create_dir_all(scripts.join("utils")).expect("the stand-in's folders");
    std::fs::write(scripts.join("utils/__init__.py"), "from .utils import *\n").expect("utils/__init__.py");
    std::fs::write(
        scripts.join("utils/utils.py"),
        "def set_cycles_renderer(scene, camera_object, num_samples,\n\
         \x20                       use_denoising: bool = True,\n\
         \x20                       prefer_cuda_use: bool = True):\n\
         \x20   pass\n",
    )
    .expect("utils/utils.py");
    for material in ["mirror", "matte_silver", "diffuse"] {
        let script = format!(
            "import inspect, os, shutil, sys\n\
             sys.path.append(os.path.dirname(os.path.abspath(__file__)))\n\
             import utils\n\
             d = inspect.signature(utils.set_cycles_renderer).parameters\n\
             assert d['use_denoising'].default is False and d['prefer_cuda_use'].default is False, 'not switched'\n\
             percent, samples, hdr, save, start, end = sys.argv[sys.argv.index('--') + 1:]\n\
             out = os.path.join(save, '{material}')\n\
             os.makedirs(out, exist_ok=True)\n\
             for name in sorted(f for f in os.listdir(hdr) if 'exr' in f)[int(start):int(end)]:\n\
             \x20   shutil.copy(os.path.join(hdr, name), os.path.join(out, name.split('-')[0]))\n"
        );
        std::fs::write(scripts.join(format!("{material}.py")), script).expect("a material's script");
    }
}
