//! Kill safety of `hdrflow run`: a run killed with SIGKILL at any moment, then run again to
//! completion on the same output and cache folders, must leave exactly the output of a clean run
//! (byte for byte, no missing or extra files, no `.tmp-` leftovers); and two runs at once on one
//! cache and one output folder must both succeed with the clean run's output.
//!
//! Kill moments: fixed delays after spawning (5, 20, 40 and 80 ms) and 25%, 50% and 75% of the
//! measured duration of a clean run; each on fresh folders, and all of them in sequence on the
//! same folders (a cache and an output folder that have survived several kills).
//!
//! Unix only: `Child::kill` is SIGKILL there (no destructors, no flushing: what a crash, the OOM
//! killer or a power cut leaves behind, short of losing the page cache).

#![cfg(unix)]

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_hdrflow");
const MANIFEST_DIR: &str = env!("CARGO_MANIFEST_DIR");
const GRAPH: &str = "graphs/seed.ron";
/// A run that has not finished by then has hung.
const TIMEOUT: Duration = Duration::from_secs(300);

/// One run's folders (and its stderr log) under a private temporary directory.
struct Dirs {
    _root: tempfile::TempDir,
    out: PathBuf,
    cache: PathBuf,
    logs: PathBuf,
}

impl Dirs {
    fn new() -> Dirs {
        let root = tempfile::tempdir().expect("temporary directory");
        let out = root.path().join("out");
        let cache = root.path().join("cache");
        let logs = root.path().join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        Dirs { out, cache, logs, _root: root }
    }
}

/// `hdrflow run graphs/seed.ron --out OUT --cache-dir CACHE -q`, from the crate folder, stderr
/// into `log` (never a pipe that could fill up and block the child).
fn spawn(out: &Path, cache: &Path, log: &Path) -> Child {
    Command::new(BIN)
        .current_dir(MANIFEST_DIR)
        .args(["run", GRAPH, "--quiet", "--out"])
        .arg(out)
        .arg("--cache-dir")
        .arg(cache)
        .env_remove("HDRFLOW_CACHE_DIR")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(File::create(log).expect("log file")))
        .spawn()
        .unwrap_or_else(|e| panic!("spawning {BIN}: {e}"))
}

/// Waits for `child`, killing it and failing after `TIMEOUT`.
fn wait(child: &mut Child, what: &str) -> ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("try_wait") {
            return status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Runs to completion and asserts exit 0; returns the wall time.
fn run_to_completion(out: &Path, cache: &Path, log: &Path, what: &str) -> Duration {
    let start = Instant::now();
    let mut child = spawn(out, cache, log);
    let status = wait(&mut child, what);
    let elapsed = start.elapsed();
    assert!(
        status.success(),
        "{what}: exit status {status}\n----- stderr -----\n{}",
        std::fs::read_to_string(log).unwrap_or_default()
    );
    elapsed
}

/// Spawns a run and SIGKILLs it after `delay` (if it has not finished by then). Returns whether
/// it was still running when killed.
fn run_and_kill(out: &Path, cache: &Path, log: &Path, delay: Duration) -> bool {
    let mut child = spawn(out, cache, log);
    let deadline = Instant::now() + delay;
    while Instant::now() < deadline {
        if child.try_wait().expect("try_wait").is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_micros(200).min(deadline.saturating_duration_since(Instant::now())));
    }
    let killed = child.try_wait().expect("try_wait").is_none();
    let _ = child.kill(); // SIGKILL
    let _ = child.wait();
    killed
}

/// Every file under `dir`, by path relative to `dir`, with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, files: &mut BTreeMap<PathBuf, Vec<u8>>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for e in entries.flatten() {
            let path = e.path();
            if path.is_dir() {
                walk(root, &path, files);
            } else {
                let bytes = std::fs::read(&path).unwrap_or_else(|err| panic!("reading {}: {err}", path.display()));
                files.insert(path.strip_prefix(root).unwrap().to_path_buf(), bytes);
            }
        }
    }
    let mut files = BTreeMap::new();
    walk(dir, dir, &mut files);
    files
}

/// Asserts that `out` holds exactly `clean`'s files with the same bytes, and no `.tmp-` file.
fn assert_same_output(out: &Path, clean: &BTreeMap<PathBuf, Vec<u8>>, what: &str) {
    let got = snapshot(out);
    let temps: Vec<&PathBuf> = got.keys().filter(|p| p.to_string_lossy().contains(".tmp-")).collect();
    assert!(temps.is_empty(), "{what}: temporary files left in the output folder: {temps:?}");
    let missing: Vec<&PathBuf> = clean.keys().filter(|p| !got.contains_key(*p)).collect();
    let extra: Vec<&PathBuf> = got.keys().filter(|p| !clean.contains_key(*p)).collect();
    let differ: Vec<&PathBuf> =
        clean.iter().filter(|(p, b)| got.get(*p).is_some_and(|g| g != *b)).map(|(p, _)| p).collect();
    assert!(
        missing.is_empty() && extra.is_empty() && differ.is_empty(),
        "{what}: output differs from a clean run: missing {missing:?}, extra {extra:?}, different bytes {differ:?}"
    );
}

/// The clean run's output and its duration (the slower of two cold runs, so that percentages
/// of it land inside a run even when the first one was slowed down by a cold disk cache).
fn clean_run() -> (BTreeMap<PathBuf, Vec<u8>>, Duration) {
    let a = Dirs::new();
    let ta = run_to_completion(&a.out, &a.cache, &a.logs.join("clean.log"), "clean run");
    let clean = snapshot(&a.out);
    assert!(!clean.is_empty(), "the clean run wrote no file");
    let b = Dirs::new();
    let tb = run_to_completion(&b.out, &b.cache, &b.logs.join("clean2.log"), "second clean run");
    // The output itself is deterministic: a precondition of comparing against it.
    assert_same_output(&b.out, &clean, "second clean run");
    (clean, ta.max(tb))
}

fn kill_delays(full: Duration) -> Vec<Duration> {
    let mut d: Vec<Duration> = [5u64, 20, 40, 80].iter().map(|&ms| Duration::from_millis(ms)).collect();
    for pct in [25u32, 50, 75] {
        d.push(full * pct / 100);
    }
    d
}

#[test]
fn killed_runs_then_completed_match_a_clean_run() {
    let (clean, full) = clean_run();
    eprintln!("clean run of {GRAPH}: {} files in {full:?}", clean.len());
    let delays = kill_delays(full);

    // Each kill moment on fresh folders.
    for (i, &delay) in delays.iter().enumerate() {
        let dirs = Dirs::new();
        let killed = run_and_kill(&dirs.out, &dirs.cache, &dirs.logs.join("killed.log"), delay);
        let what = format!(
            "kill after {delay:?} (process {}), then a full run",
            if killed { "killed" } else { "had already exited" }
        );
        run_to_completion(&dirs.out, &dirs.cache, &dirs.logs.join("rerun.log"), &what);
        assert_same_output(&dirs.out, &clean, &what);
        // Once more from the completed state: nothing changes.
        run_to_completion(&dirs.out, &dirs.cache, &dirs.logs.join(format!("again{i}.log")), &what);
        assert_same_output(&dirs.out, &clean, &format!("{what}, then another full run"));
    }

    // Every kill moment in sequence on the same folders, then one completion.
    let dirs = Dirs::new();
    for (i, &delay) in delays.iter().enumerate() {
        run_and_kill(&dirs.out, &dirs.cache, &dirs.logs.join(format!("killed{i}.log")), delay);
    }
    let what = format!("{} successive kills ({delays:?}) on the same folders, then a full run", delays.len());
    run_to_completion(&dirs.out, &dirs.cache, &dirs.logs.join("rerun.log"), &what);
    assert_same_output(&dirs.out, &clean, &what);
}

#[test]
fn two_concurrent_runs_share_a_cache_and_an_output_folder() {
    let (clean, _) = clean_run();
    // Cold cache (both compute and write everything), then warm (both read the cache).
    let dirs = Dirs::new();
    for round in ["cold cache", "warm cache"] {
        let mut a = spawn(&dirs.out, &dirs.cache, &dirs.logs.join("a.log"));
        let mut b = spawn(&dirs.out, &dirs.cache, &dirs.logs.join("b.log"));
        let sa = wait(&mut a, "first concurrent run");
        let sb = wait(&mut b, "second concurrent run");
        for (name, status, log) in [("first", sa, "a.log"), ("second", sb, "b.log")] {
            assert!(
                status.success(),
                "{round}: {name} concurrent run exited with {status}\n----- stderr -----\n{}",
                std::fs::read_to_string(dirs.logs.join(log)).unwrap_or_default()
            );
        }
        assert_same_output(&dirs.out, &clean, &format!("two concurrent runs, {round}"));
    }
}

/// BUG (found by `killed_runs_then_completed_match_a_clean_run`, which failed in 47 of 50
/// scratch runs): `engine::cache::store::write_atomic` writes each output as
/// `OUT/.NAME.tmp-PID-COUNTER-NANOS`, fsyncs it and renames it over `OUT/NAME`. A run killed
/// between the create and the rename (the fsync makes that window wide) leaves the temporary
/// file behind, and nothing ever removes it from the output folder: a later complete run
/// (`scheduler::write_output`) neither cleans it up nor ignores it (the cache folder has a
/// one-hour cleanup in `CacheStore::evict`, the output folder none). Observed leftovers, e.g.
/// `.em_64.png.tmp-23325-29-1795487431671077957` after a kill at 40 ms.
///
/// Deterministic form: plant the leftover of a dead process (its pid, an mtime two hours old),
/// run to completion, and expect it gone.
#[test]
fn regression_stale_temporary_file_in_output_folder_is_removed() {
    let (clean, _) = clean_run();
    let dirs = Dirs::new();
    // A pid that belonged to a process that has exited.
    let mut dead = Command::new("true").spawn().expect("spawning `true`");
    let pid = dead.id();
    dead.wait().unwrap();
    std::fs::create_dir_all(&dirs.out).unwrap();
    let stale = dirs.out.join(format!(".em_64.png.tmp-{pid}-0-1700000000000000000"));
    std::fs::write(&stale, b"half of a PNG").unwrap();
    let two_hours_ago = std::time::SystemTime::now() - Duration::from_secs(2 * 3600);
    File::options().write(true).open(&stale).unwrap().set_modified(two_hours_ago).unwrap();

    run_to_completion(&dirs.out, &dirs.cache, &dirs.logs.join("run.log"), "run over a stale temporary file");
    assert_same_output(&dirs.out, &clean, "a complete run over the leftover of a killed run");
}
