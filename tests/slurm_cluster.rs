//! `hdrflow batch --emit-slurm` on a REAL one-node Slurm cluster, started by the project's own
//! `scripts/slurm-cluster.sh` under this test's temporary folder (no systemd, nothing in /etc):
//! 16 maps as a 4-element job array, one running element killed for real (its whole process
//! group, SIGKILL, mid-shard), the failed shard found from the result files and resubmitted with
//! the emitted `.resubmit` script, and every output compared byte for byte with one local
//! `hdrflow batch` of the same library.
//!
//! It needs root and Debian's `slurmctld slurmd slurm-client munge` packages
//! (`scripts/slurm-cluster.sh install`; `.ci/run` does both). Without them it says loudly that it
//! skipped, unless `HDRFLOW_REQUIRE_SLURM=1` (set by `.ci/run`), which turns the skip into a failure.

mod common;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::*;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/slurm-cluster.sh");
const MAPS: usize = 16;
const SHARDS: usize = 4;
/// The element killed on purpose.
const VICTIM: usize = 1;
/// Limit for a whole array to finish (a drained node would otherwise hang the test).
const ARRAY_TIMEOUT: Duration = Duration::from_secs(240);

/// Why this machine cannot run the cluster, if it cannot.
fn unavailable() -> Option<String> {
    let uid = Command::new("id").arg("-u").output().ok().map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    if uid.as_deref() != Some("0") {
        return Some("not root (the cluster's daemons run as root)".into());
    }
    for cmd in ["slurmctld", "slurmd", "sbatch", "squeue", "munged", "setpriv"] {
        let found = Command::new("sh").arg("-c").arg(format!("command -v {cmd}")).output();
        if !found.is_ok_and(|o| o.status.success()) {
            return Some(format!("`{cmd}` not installed (run scripts/slurm-cluster.sh install)"));
        }
    }
    None
}

/// A running cluster; stopped when dropped, whatever the test did.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Cluster {
    fn start(dir: PathBuf) -> Cluster {
        // A port of its own, so a cluster left by another run cannot answer for this one.
        let port = 20000 + (std::process::id() % 5000) * 2;
        let mut cmd = Command::new("bash");
        cmd.arg(SCRIPT).arg("start").arg(&dir).env("SLURM_PORT", port.to_string());
        let cluster = Cluster { conf: dir.join("etc/slurm.conf"), dir };
        run_command(cmd, Duration::from_secs(60)).assert_success();
        cluster
    }

    /// `program ARGS` talking to this cluster, run from `cwd` to completion.
    fn run(&self, program: impl AsRef<OsStr>, args: &[&str], cwd: &Path) -> Output {
        let mut cmd = Command::new(program);
        cmd.args(args).env("SLURM_CONF", &self.conf).current_dir(cwd);
        run_command(cmd, RUN_TIMEOUT)
    }

    /// Waits until job `id` has left the queue (every element ended, one way or another).
    fn wait_for_job(&self, id: &str) {
        let start = Instant::now();
        loop {
            let o = self.run("squeue", &["-h", "-j", id, "-o", "%i %T"], &self.dir);
            // squeue fails with "Invalid job id" once the job has aged out: also gone.
            if o.stdout.trim().is_empty() {
                return;
            }
            assert!(
                start.elapsed() < ARRAY_TIMEOUT,
                "job {id} still queued after {ARRAY_TIMEOUT:?}:\n{}\n{}",
                o.stdout,
                self.logs()
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    fn logs(&self) -> String {
        ["slurmctld.log", "slurmd.log"]
            .iter()
            .map(|f| {
                let text = std::fs::read_to_string(self.dir.join("log").join(f)).unwrap_or_default();
                let tail: Vec<&str> = text.lines().rev().take(15).collect();
                format!("--- {f} (last lines)\n{}", tail.into_iter().rev().collect::<Vec<_>>().join("\n"))
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash").arg(SCRIPT).arg("stop").arg(&self.dir).output();
    }
}

/// The job id in sbatch's "Submitted batch job N".
fn job_id(out: &Output) -> String {
    out.stdout
        .lines()
        .find_map(|l| l.strip_prefix("Submitted batch job "))
        .unwrap_or_else(|| panic!("no job id\n{}", out.describe()))
        .trim()
        .to_string()
}

/// The process id of array element `task` of job `job` (the shard's `hdrflow`, which the batch
/// script `exec`s), found by its Slurm environment in /proc.
fn element_pid(job: &str, task: usize) -> Option<u32> {
    let want_job = format!("SLURM_ARRAY_JOB_ID={job}");
    let want_task = format!("SLURM_ARRAY_TASK_ID={task}");
    for entry in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else { continue };
        let comm = std::fs::read_to_string(entry.path().join("comm")).unwrap_or_default();
        if comm.trim() != "hdrflow" {
            continue;
        }
        let Ok(environ) = std::fs::read(entry.path().join("environ")) else { continue };
        let vars: Vec<&[u8]> = environ.split(|b| *b == 0).collect();
        if vars.contains(&want_job.as_bytes()) && vars.contains(&want_task.as_bytes()) {
            return Some(pid);
        }
    }
    None
}

/// The process group of `pid` (field 5 of /proc/PID/stat, after the parenthesised name).
fn process_group(pid: u32) -> Option<u32> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    stat.rsplit_once(')')?.1.split_whitespace().nth(2)?.parse().ok()
}

/// Kills array element `task` of `job` while it is mid-shard: once its process runs and its first
/// item's folder exists, SIGKILL to its whole process group (killing only the batch shell would
/// leave children running).
fn kill_element_mid_shard(job: &str, task: usize, first_item_dir: &Path, report: &Path) {
    let start = Instant::now();
    let pid = loop {
        if let Some(pid) = element_pid(job, task) {
            if first_item_dir.exists() {
                break pid;
            }
        }
        assert!(!report.exists(), "element {task} finished before it could be killed: make its items slower");
        assert!(start.elapsed() < ARRAY_TIMEOUT, "element {task} of job {job} never started its first item");
        std::thread::sleep(Duration::from_millis(5));
    };
    let own_group = process_group(std::process::id());
    let target = match process_group(pid) {
        Some(g) if Some(g) != own_group => format!("-{g}"),
        _ => pid.to_string(),
    };
    let o = Command::new("kill").args(["-KILL", "--", &target]).output().expect("kill runs");
    assert!(o.status.success(), "kill {target}: {}", String::from_utf8_lossy(&o.stderr));
    assert!(!report.exists(), "element {task} wrote its report before the kill landed: make its items slower");
}

fn batch_args(out: &str, cache: &str) -> Vec<String> {
    ["batch", "graphs/seed.ron", "--over", "env.path=maps/*.pfm", "--out", out, "--cache-dir", cache, "--jobs", "1"]
        .map(String::from)
        .into()
}

fn hdrflow_in(sb: &Sandbox, args: &[String]) -> Output {
    let mut cmd = hdrflow_command(args);
    cmd.current_dir(sb.path());
    run_command(cmd, RUN_TIMEOUT)
}

#[test]
fn a_real_job_array_survives_a_killed_element_and_matches_one_machine() {
    if let Some(why) = unavailable() {
        return common::skip("HDRFLOW_REQUIRE_SLURM", &format!("the real Slurm cluster test cannot run: {why}"));
    }
    let sb = Sandbox::new();
    // The seed graph over 16 maps (512x256: about a third of a second per item here, so an
    // element of four items is still running when it is killed).
    std::fs::create_dir_all(sb.join("graphs")).unwrap();
    std::fs::copy(Path::new(MANIFEST_DIR).join("graphs/seed.ron"), sb.join("graphs/seed.ron")).unwrap();
    for i in 0..MAPS {
        sb.write(format!("maps/m{i:02}.pfm"), small_pfm(512, 256, 0.5 + i as f32 * 0.25));
    }
    let cluster = Cluster::start(sb.join("cluster"));

    let emit = [
        batch_args("out", "shared cache"),
        ["--emit-slurm", "bake.sbatch", "--shards", &SHARDS.to_string(), "--slurm-arg", "time=00:10:00"]
            .map(String::from)
            .into(),
    ]
    .concat();
    hdrflow_in(&sb, &emit).assert_success();

    let submitted = Instant::now();
    let o = cluster.run("sbatch", &["bake.sbatch"], sb.path());
    o.assert_success();
    let job = job_id(&o);
    let report = sb.join(format!("out/shards/shard-{VICTIM}-of-{SHARDS}.json"));
    kill_element_mid_shard(&job, VICTIM, &sb.join(format!("out/m{VICTIM:02}")), &report);
    cluster.wait_for_job(&job);
    let array_time = submitted.elapsed();

    // Only the killed element's shard is unfinished, decided from the result files.
    let failed = |sb: &Sandbox| {
        let o = hdrflow_in(
            sb,
            &[batch_args("out", "shared cache"), vec!["--failed-shards".into(), SHARDS.to_string()]].concat(),
        );
        o.assert_success();
        o.stdout.trim().to_string()
    };
    assert_eq!(failed(&sb), VICTIM.to_string(), "{}", cluster.logs());
    for i in (0..SHARDS).filter(|i| *i != VICTIM) {
        assert!(sb.join(format!("out/shards/shard-{i}-of-{SHARDS}.json")).is_file(), "shard {i}\n{}", cluster.logs());
    }

    // The emitted companion resubmits exactly that shard, through the real sbatch.
    let o = cluster.run(sb.join("bake.sbatch.resubmit"), &[], sb.path());
    o.assert_success();
    assert!(o.stdout.contains(&format!("resubmitting shards {VICTIM} of {SHARDS}")), "{}", o.describe());
    cluster.wait_for_job(&job_id(&o));
    assert_eq!(failed(&sb), "", "{}", cluster.logs());
    let o = cluster.run(sb.join("bake.sbatch.resubmit"), &[], sb.path());
    assert!(o.stdout.contains(&format!("all {SHARDS} shards finished")), "{}", o.describe());
    // Slurm wrote one log per element run: four, plus the resubmitted one.
    let logs = std::fs::read_dir(sb.join("out/slurm")).unwrap().count();
    assert_eq!(logs, SHARDS + 1);

    // Byte-identical to one local batch on its own cache.
    let local = Instant::now();
    hdrflow_in(&sb, &batch_args("local", "local cache")).assert_success();
    let local_time = local.elapsed();
    let reference = batch_outputs(&sb.join("local"));
    let per_item = reference.len() / MAPS;
    assert!(per_item >= 10 && reference.len() == per_item * MAPS, "{} outputs", reference.len());
    let got = batch_outputs(&sb.join("out"));
    let names = |v: &[(PathBuf, Vec<u8>)]| v.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
    assert_eq!(names(&got), names(&reference));
    for ((path, a), (_, b)) in got.iter().zip(&reference) {
        assert!(a == b, "{} differs between the Slurm array and the local batch", path.display());
    }
    eprintln!(
        "slurm array of {MAPS} maps in {SHARDS} elements (one killed): {array_time:.2?} to the end of the first \
         array; local batch --jobs 1: {local_time:.2?}"
    );
}
