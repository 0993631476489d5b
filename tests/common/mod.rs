//! Shared helpers for the end-to-end tests: running the `hdrflow` binary (with a timeout, capturing
//! stdout, stderr and the exit code), per-test sandboxes (their own output and cache folders, never
//! the user's cache), files, run reports and `plan` tables.

#![allow(dead_code)]

use std::cell::Cell;
use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_hdrflow");
/// The crate folder (`tests/bad/...` and `graphs/...` are relative to it).
pub const MANIFEST_DIR: &str = env!("CARGO_MANIFEST_DIR");
/// Generous limit for one ordinary run on tiny images (a hang fails instead of blocking forever).
pub const RUN_TIMEOUT: Duration = Duration::from_secs(120);

/// What a finished command did.
#[derive(Debug)]
pub struct Output {
    pub cmdline: String,
    /// `None` when killed by a signal.
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
    /// Wall time from spawn to exit.
    pub elapsed: Duration,
}

impl Output {
    /// Everything about the run, for assertion messages.
    pub fn describe(&self) -> String {
        format!(
            "command: {}\nexit code: {:?} after {:.3?}\n----- stdout -----\n{}\n----- stderr -----\n{}\n------------------",
            self.cmdline, self.code, self.elapsed, self.stdout, self.stderr
        )
    }

    #[track_caller]
    pub fn assert_code(&self, code: i32) -> &Self {
        assert_eq!(self.code, Some(code), "expected exit code {code}\n{}", self.describe());
        self
    }

    #[track_caller]
    pub fn assert_success(&self) -> &Self {
        self.assert_code(0)
    }

    #[track_caller]
    pub fn assert_stderr_contains(&self, needle: &str) -> &Self {
        assert!(self.stderr.contains(needle), "stderr does not contain {needle:?}\n{}", self.describe());
        self
    }

    #[track_caller]
    pub fn assert_stdout_contains(&self, needle: &str) -> &Self {
        assert!(self.stdout.contains(needle), "stdout does not contain {needle:?}\n{}", self.describe());
        self
    }
}

/// A spawned command whose output is being collected.
pub struct Running {
    cmdline: String,
    child: Child,
    start: Instant,
    stdout: JoinHandle<Vec<u8>>,
    stderr: JoinHandle<Vec<u8>>,
}

fn reader(mut pipe: impl Read + Send + 'static) -> JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut buf = Vec::new();
        let _ = pipe.read_to_end(&mut buf);
        buf
    })
}

/// Starts `cmd` with stdin closed and stdout/stderr captured.
pub fn spawn(mut cmd: Command) -> Running {
    let cmdline = format!("{cmd:?}");
    cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    let start = Instant::now();
    let mut child = cmd.spawn().unwrap_or_else(|e| panic!("cannot start {cmdline}: {e}"));
    let stdout = reader(child.stdout.take().expect("piped stdout"));
    let stderr = reader(child.stderr.take().expect("piped stderr"));
    Running { cmdline, child, start, stdout, stderr }
}

impl Running {
    /// Waits for the command; kills it and panics if it runs longer than `timeout`.
    pub fn wait(mut self, timeout: Duration) -> Output {
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) => {
                    if self.start.elapsed() > timeout {
                        let _ = self.child.kill();
                        let _ = self.child.wait();
                        // The reader threads are not joined: a grandchild may still hold the pipes.
                        panic!("timed out after {timeout:?} (killed): {}", self.cmdline);
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => panic!("waiting for {}: {e}", self.cmdline),
            }
        };
        let elapsed = self.start.elapsed();
        let stdout = self.stdout.join().expect("stdout reader");
        let stderr = self.stderr.join().expect("stderr reader");
        Output {
            cmdline: self.cmdline,
            code: status.code(),
            stdout: String::from_utf8_lossy(&stdout).into_owned(),
            stderr: String::from_utf8_lossy(&stderr).into_owned(),
            elapsed,
        }
    }
}

/// Runs `cmd` to completion (see [`Running::wait`]).
pub fn run_command(cmd: Command, timeout: Duration) -> Output {
    spawn(cmd).wait(timeout)
}

/// `hdrflow ARGS...` run from the crate folder. The default cache folder is pointed away from
/// the user's (`HDRFLOW_CACHE_DIR`) as a safety net; every test still passes `--cache-dir`.
pub fn hdrflow_command<I, S>(args: I) -> Command
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let mut cmd = Command::new(BIN);
    cmd.args(args).current_dir(MANIFEST_DIR);
    cmd.env("HDRFLOW_CACHE_DIR", std::env::temp_dir().join("hdrflow-tests-never-used-cache"));
    cmd.env_remove("XDG_CACHE_HOME");
    cmd
}

/// Runs `hdrflow ARGS...` from the crate folder and returns what it did.
pub fn run_hdrflow<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    run_command(hdrflow_command(args), RUN_TIMEOUT)
}

/// Writes `bytes` to `path`, creating its folders.
pub fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> PathBuf {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("creating {}: {e}", dir.display()));
    }
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
    path.to_path_buf()
}

#[track_caller]
pub fn read_file(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
}

/// Every regular file under `dir`, recursively, as paths relative to `dir`, sorted. A folder that
/// does not exist has no files.
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let Ok(kind) = entry.file_type() else {
                continue;
            };
            if kind.is_dir() {
                walk(root, &path, out);
            } else if kind.is_file() {
                out.push(path.strip_prefix(root).expect("under root").to_path_buf());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// A RON string literal for `s` (Rust's `Debug` escapes are within the pipeline syntax).
pub fn ron_str(s: impl AsRef<str>) -> String {
    format!("{:?}", s.as_ref())
}

/// A RON string literal for a path.
pub fn ron_path(p: &Path) -> String {
    ron_str(p.to_str().expect("test paths are UTF-8"))
}

/// A run report (`--report FILE`), by node name.
#[derive(Debug, Clone)]
pub struct Report {
    /// name -> "computed" | "cached" | "not needed"
    pub status: BTreeMap<String, String>,
    /// name -> hex cache key ("" when not needed)
    pub key: BTreeMap<String, String>,
    pub json: serde_json::Value,
}

impl Report {
    #[track_caller]
    pub fn status_of(&self, node: &str) -> &str {
        self.status
            .get(node)
            .map(String::as_str)
            .unwrap_or_else(|| panic!("no node {node:?} in report {:#?}", self.status))
    }

    #[track_caller]
    pub fn key_of(&self, node: &str) -> &str {
        self.key.get(node).map(String::as_str).unwrap_or_else(|| panic!("no node {node:?} in report {:#?}", self.key))
    }

    /// Names of the nodes with this status.
    pub fn with_status(&self, status: &str) -> Vec<&str> {
        self.status.iter().filter(|(_, s)| s.as_str() == status).map(|(n, _)| n.as_str()).collect()
    }
}

/// Reads a report JSON: `{"total_ms": f64, "nodes": [{"name", "op", "status", "ms", "key"}]}`.
#[track_caller]
pub fn read_report(path: &Path) -> Report {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading report {}: {e}", path.display()));
    let json: serde_json::Value =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("report {} is not JSON: {e}\n{text}", path.display()));
    assert!(json["total_ms"].is_number(), "report has no numeric total_ms:\n{text}");
    let nodes = json["nodes"].as_array().unwrap_or_else(|| panic!("report has no nodes array:\n{text}"));
    let mut status = BTreeMap::new();
    let mut key = BTreeMap::new();
    for n in nodes {
        let name = n["name"].as_str().unwrap_or_else(|| panic!("node without a name in report:\n{text}")).to_string();
        let s = n["status"].as_str().unwrap_or_else(|| panic!("node {name} without a status:\n{text}")).to_string();
        assert!(
            matches!(s.as_str(), "computed" | "cached" | "not needed"),
            "node {name}: unexpected status {s:?}:\n{text}"
        );
        assert!(n["op"].is_string(), "node {name} without an op:\n{text}");
        assert!(n["ms"].is_number(), "node {name} without ms:\n{text}");
        let k = n["key"].as_str().unwrap_or_else(|| panic!("node {name} without a key:\n{text}")).to_string();
        key.insert(name.clone(), k);
        status.insert(name, s);
    }
    Report { status, key, json }
}

/// The brief's helper: a report as name -> status.
pub fn read_report_statuses(path: &Path) -> BTreeMap<String, String> {
    read_report(path).status
}

/// Parses the table `hdrflow plan` prints: name -> "computed" | "cached" | "not needed".
pub fn parse_plan(stdout: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for line in stdout.lines().skip(1) {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.len() < 3 || t[1] == "nodes:" {
            continue;
        }
        let what = if t[2] == "not" && t.get(3) == Some(&"needed") { "not needed" } else { t[2] };
        out.insert(t[0].to_string(), what.to_string());
    }
    out
}

/// A test's private folder: pipeline files and inputs at its root, `out/` and `cache/` beside.
pub struct Sandbox {
    pub dir: tempfile::TempDir,
    reports: Cell<u32>,
}

impl Default for Sandbox {
    fn default() -> Self {
        Self::new()
    }
}

impl Sandbox {
    pub fn new() -> Self {
        let dir = tempfile::Builder::new().prefix("hdrflow-e2e-").tempdir().expect("temporary folder");
        Sandbox { dir, reports: Cell::new(0) }
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    pub fn join(&self, rel: impl AsRef<Path>) -> PathBuf {
        self.dir.path().join(rel)
    }

    /// The default output folder.
    pub fn out(&self) -> PathBuf {
        self.join("out")
    }

    /// The default cache folder.
    pub fn cache(&self) -> PathBuf {
        self.join("cache")
    }

    /// Writes a file relative to the sandbox.
    pub fn write(&self, rel: impl AsRef<Path>, bytes: impl AsRef<[u8]>) -> PathBuf {
        write_file(&self.join(rel), bytes)
    }

    /// A fresh report path.
    pub fn next_report(&self) -> PathBuf {
        let n = self.reports.get() + 1;
        self.reports.set(n);
        self.join(format!("report-{n}.json"))
    }

    /// `hdrflow run GRAPH --out OUT --cache-dir CACHE --report R EXTRA...` as a command.
    pub fn run_command(&self, graph: &Path, out: &Path, cache: &Path, report: &Path, extra: &[&str]) -> Command {
        let mut cmd = hdrflow_command([OsStr::new("run"), graph.as_os_str()]);
        cmd.arg("--out").arg(out).arg("--cache-dir").arg(cache).arg("--report").arg(report);
        cmd.args(extra);
        cmd.env("HDRFLOW_CACHE_DIR", cache);
        cmd
    }

    /// Runs the pipeline with the sandbox's `out/` and `cache/`; returns the output and, when
    /// the run succeeded, its report.
    pub fn run(&self, graph: &Path, extra: &[&str]) -> (Output, Option<Report>) {
        self.run_in(graph, &self.out(), &self.cache(), extra)
    }

    /// Like [`Sandbox::run`] with explicit output and cache folders.
    pub fn run_in(&self, graph: &Path, out: &Path, cache: &Path, extra: &[&str]) -> (Output, Option<Report>) {
        let report = self.next_report();
        let output = run_command(self.run_command(graph, out, cache, &report, extra), RUN_TIMEOUT);
        let report = (output.code == Some(0)).then(|| read_report(&report));
        (output, report)
    }

    /// Runs and asserts success; returns the output and the report.
    #[track_caller]
    pub fn run_ok(&self, graph: &Path, extra: &[&str]) -> (Output, Report) {
        let (output, report) = self.run(graph, extra);
        output.assert_success();
        (output, report.expect("a successful run writes its report"))
    }

    /// `hdrflow plan GRAPH --cache-dir CACHE EXTRA...`, asserting success; returns the plan table.
    #[track_caller]
    pub fn plan(&self, graph: &Path, extra: &[&str]) -> BTreeMap<String, String> {
        let mut cmd = hdrflow_command([OsStr::new("plan"), graph.as_os_str()]);
        cmd.arg("--out").arg(self.out()).arg("--cache-dir").arg(self.cache()).args(extra);
        cmd.env("HDRFLOW_CACHE_DIR", self.cache());
        let output = run_command(cmd, RUN_TIMEOUT);
        output.assert_success();
        let plan = parse_plan(&output.stdout);
        assert!(!plan.is_empty(), "plan printed no nodes\n{}", output.describe());
        plan
    }
}

/// Asserts that `map[name] == want` for every pair, with the whole map in the message.
#[track_caller]
pub fn assert_statuses(map: &BTreeMap<String, String>, want: &[(&str, &str)], context: &str) {
    for (name, status) in want {
        assert_eq!(
            map.get(*name).map(String::as_str),
            Some(*status),
            "node {name:?}: expected {status:?}; all: {map:#?}\n{context}"
        );
    }
}

#[path = "../../src/test_skip.rs"]
mod test_skip;
#[allow(unused_imports)]
pub use test_skip::{real_map, skip, skip_missing_data};

/// A small RGB PFM map (little-endian) whose values grow with x, y and the channel, times
/// `scale`: a library of distinct maps for the batch tests.
pub fn small_pfm(w: usize, h: usize, scale: f32) -> Vec<u8> {
    let mut b = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let v = scale * (1.0 + x as f32 / w as f32 + y as f32 / h as f32 + c as f32 * 0.1);
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    b
}

/// The batch tests' pipeline: a map (`env`, at `env_path`) blurred and compared with itself,
/// beside nodes no swept field reaches (computed once per batch).
pub fn batch_graph(env_path: &str) -> String {
    format!(
        r#"( nodes: {{
  "env":  LoadHdr(path: "{env_path}"),
  "flat": Constant(width: 16, height: 8, color: 0.25),
  "soft": Blur(image: "flat", sigma: 2),
  "blur": Blur(image: "env", sigma: 3, wrap: true),
  "e":    Exposure(image: "blur", stops: 0),
  "diff": Difference(a: "e", b: "env"),
  "s1":   Save(input: "e", path: "e.pfm"),
  "s2":   Save(input: "diff.metrics", path: "m.json"),
  "s3":   Save(input: "soft", path: "soft.pfm"),
}} )"#
    )
}

/// Every item output of a batch folder with its bytes, sorted by path: what two batches must agree
/// on byte for byte (the batch's own reports, shard reports and Slurm logs left out).
pub fn batch_outputs(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    files_under(dir)
        .into_iter()
        .filter(|p| {
            let s = p.to_string_lossy();
            // The report's files (batch, metrics and summary tables), the shards' reports and logs.
            !["batch", "metrics", "summary", "shards/", "slurm/"].iter().any(|r| s.starts_with(r))
        })
        .map(|p| {
            let bytes = read_file(&dir.join(&p));
            (p, bytes)
        })
        .collect()
}

/// Runs pipeline text in this process (no cache, two threads) and returns the targets' values
/// by `node` / `node.port`, or the error as text.
pub fn run_text(text: &str, targets: &[&str]) -> Result<BTreeMap<String, hdrflow::engine::value::Value>, String> {
    use hdrflow::engine::scheduler::{self, RunOptions, Silent};
    static RUNS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let registry = hdrflow::builtin_registry();
    let p = hdrflow::Pipeline::parse(text, "test.ron", Path::new("."), &registry, &[]).map_err(|e| e.to_string())?;
    let n = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let out = std::env::temp_dir().join(format!("hdrflow-in-process-{}-{n}", std::process::id()));
    let options = RunOptions {
        targets: targets.iter().map(|t| t.to_string()).collect(),
        out_dir: out,
        cache: None,
        jobs: Some(2),
        observer: &Silent,
    };
    scheduler::run(&p, &options).map(|o| o.values).map_err(|e| e.to_string())
}

/// The Python with NumPy (and OpenCV) that runs the peers of `bench/peers/` inside tests:
/// `HDRFLOW_PEER_PYTHON`, else the venv `scripts/peer-venv.sh` makes (`target/peer-venv`);
/// `None` after a visible skip (a failure under `HDRFLOW_REQUIRE_PEERS=1`, as `.ci/run` sets it).
#[allow(dead_code)]
pub fn peer_python() -> Option<PathBuf> {
    let python = match std::env::var_os("HDRFLOW_PEER_PYTHON") {
        Some(p) => PathBuf::from(p),
        None => Path::new(MANIFEST_DIR).join("target/peer-venv/bin/python"),
    };
    if python.is_file() {
        return Some(python);
    }
    skip(
        "HDRFLOW_REQUIRE_PEERS",
        &format!("no peer Python at {} (make it with `bash scripts/peer-venv.sh`)", python.display()),
    );
    None
}
