//! `hdrflow batch --emit-slurm` and `--failed-shards`, through a FAKE `sbatch` (a shell script put
//! first on PATH that runs each array element in turn with `SLURM_ARRAY_TASK_ID` set). This tests
//! the scripts' logic only, not a real Slurm cluster.

mod common;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use common::*;

/// Six maps in a folder whose name has a space and a quote, and a pipeline over them.
const MAPS: &str = "my 'maps'";

fn library(sb: &Sandbox) {
    for i in 0..6 {
        sb.write(format!("{MAPS}/m{i}.pfm"), common::small_pfm(16, 8, 1.0 + i as f32));
    }
    sb.write("g.ron", common::batch_graph("unused.pfm"));
}

/// The fake `sbatch`: `--array=LIST` from the command line, else from the script's `#SBATCH
/// --array=` line; runs every element in turn (failures ignored), logging the command line.
const FAKE_SBATCH: &str = r#"#!/bin/sh
array=""
script=""
for a in "$@"; do
    case "$a" in
        --array=*) array="${a#--array=}" ;;
        -*) ;;
        *) script="$a" ;;
    esac
done
[ -n "$array" ] || array=$(sed -n 's/^#SBATCH --array=//p' "$script" | head -n 1)
echo "sbatch --array=$array" >> "$FAKE_SBATCH_LOG"
for part in $(echo "$array" | tr ',' ' '); do
    case "$part" in
        *-*) lo=${part%-*}; hi=${part#*-} ;;
        *) lo=$part; hi=$part ;;
    esac
    i=$lo
    while [ "$i" -le "$hi" ]; do
        echo "element $i" >> "$FAKE_SBATCH_LOG"
        SLURM_ARRAY_JOB_ID=1 SLURM_ARRAY_TASK_ID=$i "$script" >> "$FAKE_SBATCH_LOG" 2>&1 || echo "ELEMENT $i FAILED" >> "$FAKE_SBATCH_LOG"
        i=$((i + 1))
    done
done
echo "Submitted batch job 1"
"#;

struct Fake {
    bin: PathBuf,
    log: PathBuf,
}

fn fake_sbatch(sb: &Sandbox) -> Fake {
    let bin = sb.join("fake bin");
    let path = sb.write("fake bin/sbatch", FAKE_SBATCH);
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    Fake { bin, log: sb.join("sbatch.log") }
}

impl Fake {
    /// `cmd` with the fake `sbatch` first on PATH, run from `cwd`.
    fn run(&self, mut cmd: Command, cwd: &Path) -> Output {
        let path = std::env::var_os("PATH").unwrap_or_default();
        let mut dirs = vec![self.bin.clone()];
        dirs.extend(std::env::split_paths(&path));
        cmd.env("PATH", std::env::join_paths(dirs).unwrap()).env("FAKE_SBATCH_LOG", &self.log).current_dir(cwd);
        run_command(cmd, Duration::from_secs(120))
    }
    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

/// The batch options, relative to the sandbox (the emitted scripts must resolve them).
fn batch_args(out: &str, cache: &str, extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> =
        ["batch", "g.ron", "--over", &format!("env.path={MAPS}/*.pfm"), "--out", out, "--cache-dir", cache]
            .map(String::from)
            .into();
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

fn hdrflow_in(sb: &Sandbox, args: &[String]) -> Output {
    let mut cmd = hdrflow_command(args);
    cmd.current_dir(sb.path());
    run_command(cmd, RUN)
}

const RUN: Duration = Duration::from_secs(120);

#[test]
fn emitted_job_array_runs_resubmits_failed_shards_and_matches_one_process() {
    let sb = Sandbox::new();
    library(&sb);
    let fake = fake_sbatch(&sb);
    let out = "out dir";
    let opts = ["--jobs", "2", "--keep-going"];
    let emit = [
        batch_args(out, "shared cache", &opts),
        [
            "--emit-slurm",
            "job script.sh",
            "--shards",
            "3",
            "--slurm-arg",
            "time=00:10:00",
            "--slurm-arg",
            "job-name=lib",
        ]
        .map(String::from)
        .into(),
    ]
    .concat();
    hdrflow_in(&sb, &emit).assert_success();
    let script_path = sb.join("job script.sh");
    let script = std::fs::read_to_string(&script_path).unwrap();
    let mode = std::fs::metadata(&script_path).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o755, "{script}");
    for line in [
        "#SBATCH --array=0-2",
        "#SBATCH --job-name=lib",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --time=00:10:00",
        "set -euo pipefail",
        "--shard \"$SLURM_ARRAY_TASK_ID/3\"",
    ] {
        assert!(script.contains(line), "{line:?} missing:\n{script}");
    }
    let abs_out = sb.join(out);
    assert!(script.contains(&format!("#SBATCH --output=\"{}/slurm/%A_%a.out\"", abs_out.display())), "{script}");
    assert!(!script.contains("#SBATCH --job-name=hdrflow-batch"), "{script}");
    assert!(abs_out.join("slurm").is_dir() && abs_out.join("shards").is_dir());
    let resubmit = sb.join("job script.sh.resubmit");
    assert_eq!(std::fs::metadata(&resubmit).unwrap().permissions().mode() & 0o777, 0o755);

    // Nothing ran yet: every shard is unfinished.
    let failed = |sb: &Sandbox| {
        let o = hdrflow_in(
            sb,
            &[batch_args(out, "shared cache", &opts), vec!["--failed-shards".into(), "3".into()]].concat(),
        );
        o.assert_success();
        o.stdout.trim().to_string()
    };
    assert_eq!(failed(&sb), "0-2");

    // Submit from another folder: the script must not depend on the caller's working folder.
    let elsewhere = sb.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let mut sbatch = Command::new("sbatch");
    sbatch.arg(&script_path);
    let o = fake.run(sbatch, &elsewhere);
    assert!(o.stdout.contains("Submitted batch job"), "{}\n{}", o.describe(), fake.log());
    assert!(!fake.log().contains("FAILED"), "{}", fake.log());
    assert_eq!(failed(&sb), "", "{}", fake.log());
    for i in 0..3 {
        assert!(abs_out.join(format!("shards/shard-{i}-of-3.json")).is_file());
    }
    assert_eq!(files_under(&abs_out.join("m4")).len(), 3, "{}", fake.log());

    // Simulate a killed element (shard 1: no report, an item's folder gone) and an element that
    // failed on one item (shard 2: that row failed, its output torn).
    std::fs::remove_file(abs_out.join("shards/shard-1-of-3.json")).unwrap();
    std::fs::remove_dir_all(abs_out.join("m4")).unwrap();
    let r2 = abs_out.join("shards/shard-2-of-3.json");
    let mut rows: serde_json::Value = serde_json::from_slice(&read_file(&r2)).unwrap();
    let row = rows.as_array_mut().unwrap().iter_mut().find(|r| r["item"] == "m5").expect("m5 in shard 2");
    row["status"] = "failed".into();
    row["error"] = "killed".into();
    std::fs::write(&r2, serde_json::to_vec(&rows).unwrap()).unwrap();
    let torn = abs_out.join("m5/e.pfm");
    let len = read_file(&torn).len();
    std::fs::write(&torn, &read_file(&torn)[..len / 2]).unwrap();
    assert_eq!(failed(&sb), "1,2");

    let o = fake.run(Command::new(&resubmit), &elsewhere);
    o.assert_success();
    assert!(o.stdout.contains("resubmitting shards 1,2 of 3"), "{}", o.describe());
    assert!(fake.log().contains("sbatch --array=1,2\n"), "{}", fake.log());
    assert_eq!(failed(&sb), "", "{}", fake.log());
    let o = fake.run(Command::new(&resubmit), &elsewhere);
    o.assert_success();
    assert!(o.stdout.contains("all 3 shards finished"), "{}", o.describe());

    // Byte-identical to one process on its own cache.
    hdrflow_in(&sb, &batch_args("reference", "ref cache", &opts)).assert_success();
    let reference = batch_outputs(&sb.join("reference"));
    assert_eq!(reference.len(), 18, "{:?}", reference.iter().map(|r| &r.0).collect::<Vec<_>>());
    assert_eq!(batch_outputs(&abs_out), reference);
}

#[test]
fn a_report_missing_an_item_or_a_bad_option_is_caught() {
    let sb = Sandbox::new();
    library(&sb);
    let run = |extra: &[&str]| hdrflow_in(&sb, &batch_args("o", "c", extra));
    // A shard stopped at its first failure writes a report without the items it never started.
    run(&["--shard", "0/2", "--report", "o/shards/shard-0-of-2.json"]).assert_success();
    run(&["--shard", "1/2", "--report", "o/shards/shard-1-of-2.json"]).assert_success();
    assert_eq!(run(&["--failed-shards", "2"]).stdout.trim(), "");
    let r = sb.join("o/shards/shard-1-of-2.json");
    let mut rows: serde_json::Value = serde_json::from_slice(&read_file(&r)).unwrap();
    rows.as_array_mut().unwrap().pop();
    std::fs::write(&r, serde_json::to_vec(&rows).unwrap()).unwrap();
    let o = run(&["--failed-shards", "2"]);
    assert_eq!(o.stdout.trim(), "1", "{}", o.describe());
    assert!(o.stderr.contains("not in"), "{}", o.describe());
    std::fs::write(&r, "{ torn").unwrap();
    assert_eq!(run(&["--failed-shards", "2"]).stdout.trim(), "1");

    // A shard that stops at a failing item reports the items it never started.
    let mut broken = common::small_pfm(16, 8, 1.0);
    broken.truncate(broken.len() / 2);
    sb.write(format!("{MAPS}/m0.pfm"), broken);
    run(&["--shard", "0/2", "--report", "o/shards/shard-0-of-2.json", "--jobs", "1"]).assert_code(1);
    let rows: serde_json::Value = serde_json::from_slice(&read_file(&sb.join("o/shards/shard-0-of-2.json"))).unwrap();
    let statuses: Vec<&str> = rows.as_array().unwrap().iter().map(|r| r["status"].as_str().unwrap()).collect();
    assert_eq!(statuses, ["failed", "not started", "not started"], "{rows}");
    let o = run(&["--failed-shards", "2"]);
    assert_eq!(o.stdout.trim(), "0,1", "{}", o.describe());

    run(&["--emit-slurm", "j.sh", "--slurm-arg", "bad key=1"]).assert_code(2);
    run(&["--emit-slurm", "j.sh", "--shard", "0/2"]).assert_code(2);
    run(&["--shards", "2"]).assert_code(2);
    assert!(!sb.join("j.sh").exists());
}
