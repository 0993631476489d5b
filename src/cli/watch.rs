//! `hdrflow watch GRAPH [run options]`: run, then rerun whenever the pipeline file or a file it
//! reads changes, until Ctrl-C.
//!
//! - Changes are seen through the `notify` crate (inotify on Linux). The *folders* of the watched
//!   files are watched, not the files, so that an editor's save-by-rename (write a temporary
//!   file, rename it over the original) is seen like an in-place write.
//! - Events are debounced: after the first relevant one, the rerun waits until no further event
//!   has come for `--debounce-ms` (editors write a file in several steps).
//! - Each rerun reloads and revalidates the file and runs against the cache, so only what
//!   changed is recomputed; it prints one summary line. A pipeline error is printed with its
//!   `file:line:col` and the watch goes on; so does a run error.
//! - With `--html FILE` the page is rewritten after every run and reloads itself every second.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::Duration;

use clap::Args;
use notify::event::{AccessKind, AccessMode, ModifyKind};
use notify::{EventKind, RecursiveMode, Watcher};

use super::{cache_of, load_or_message, now_hms, progress, write_html, write_report, RunArgs};
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions};

#[derive(Args)]
pub(crate) struct WatchArgs {
    #[command(flatten)]
    run: RunArgs,
    /// Quiet time after the last file event before a rerun, in milliseconds.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u64).range(0..=60_000))]
    debounce_ms: u64,
}

enum Message {
    Files(Vec<PathBuf>),
    Stop,
}

pub(crate) fn watch(registry: &Registry, args: &WatchArgs) -> ExitCode {
    // Options whose output is one value for one run make no sense for a stream of runs.
    if args.run.json || !args.run.print.is_empty() || args.run.verbose {
        eprintln!("error: watch prints one summary line per run: --json, --print and -v are for `hdrflow run`");
        return ExitCode::from(2);
    }
    let (tx, rx) = mpsc::channel::<Message>();
    let stop = tx.clone();
    if let Err(e) = ctrlc::set_handler(move || {
        let _ = stop.send(Message::Stop);
    }) {
        eprintln!("warning: Ctrl-C will not stop the watch cleanly: {e}");
    }
    let mut watcher = match notify::recommended_watcher(move |event: notify::Result<notify::Event>| {
        // Content changes only: reading a file (ours included, every run) raises access events.
        if let Ok(event) = event {
            if is_change(&event.kind) {
                let _ = tx.send(Message::Files(event.paths));
            }
        }
    }) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("error: cannot watch files: {e}");
            return ExitCode::from(1);
        }
    };
    let mut watched_dirs: BTreeSet<PathBuf> = BTreeSet::new();
    let mut files: Vec<PathBuf> = vec![absolute(&args.run.graph.graph)];
    let mut changed: Vec<PathBuf> = Vec::new();
    let mut runs = 0;
    loop {
        runs += 1;
        let (next, summary) = run_once(registry, args, runs, &changed, &files);
        files = next;
        let dirs: BTreeSet<PathBuf> = files.iter().filter_map(|f| f.parent().map(Path::to_path_buf)).collect();
        for d in watched_dirs.difference(&dirs) {
            let _ = watcher.unwatch(d);
        }
        for d in dirs.difference(&watched_dirs) {
            if let Err(e) = watcher.watch(d, RecursiveMode::NonRecursive) {
                eprintln!("warning: cannot watch {}: {e}", d.display());
            }
        }
        watched_dirs = dirs;
        // The summary line last: whoever reads it finds the page and the report written and
        // every file watched (a save right after it is seen).
        outln!("{summary}");
        match wait_for_change(&rx, &files, Duration::from_millis(args.debounce_ms)) {
            Some(c) => changed = c,
            None => {
                eprintln!("watch: stopped after {runs} run{}", if runs == 1 { "" } else { "s" });
                return ExitCode::SUCCESS;
            }
        }
    }
}

/// One run; returns the files to watch next (the pipeline file and every file it reads; after a
/// pipeline error, the previous list, so that fixing any of them reruns) and its summary line.
fn run_once(
    registry: &Registry,
    args: &WatchArgs,
    n: usize,
    changed: &[PathBuf],
    previous: &[PathBuf],
) -> (Vec<PathBuf>, String) {
    let run = &args.run;
    let why = if changed.is_empty() {
        String::new()
    } else {
        let names: Vec<String> = changed
            .iter()
            .map(|p| p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned()))
            .collect();
        format!(" ({} changed)", names.join(", "))
    };
    let p = match load_or_message(registry, &run.graph) {
        Ok(p) => p,
        Err(message) => {
            eprint!("{message}");
            if let Some(html) = &run.html {
                let subtitle = format!("hdrflow watch: run {n} at {}", now_hms());
                write_html(html, None, None, run, Some(message), Some(1), subtitle);
            }
            let line = format!("[{}] run {n}{why}: the pipeline has errors; fix the file and save", now_hms());
            return (previous.to_vec(), line);
        }
    };
    let observer = progress::Progress::new(progress::Verbosity::Quiet);
    let options = RunOptions {
        targets: run.targets.clone(),
        out_dir: run.out.clone(),
        cache: cache_of(run),
        jobs: run.jobs.filter(|&j| j > 0),
        observer: &observer,
    };
    let outcome = scheduler::run(&p, &options);
    observer.finish();
    let subtitle = format!("hdrflow watch: run {n} at {}", now_hms());
    let line = match &outcome {
        Ok(o) => {
            let r = &o.report;
            if let Some(html) = &run.html {
                write_html(html, Some(&p), Some(r), run, None, Some(1), subtitle);
            }
            if let Some(path) = &run.report {
                if let Err(e) = write_report(path, r) {
                    eprintln!("warning: {e}");
                }
            }
            format!(
                "[{}] run {n}{why}: {} computed, {} cached, {} not needed; {:.1} ms; {} file{} written",
                now_hms(),
                r.count(NodeStatus::Computed),
                r.count(NodeStatus::Cached),
                r.count(NodeStatus::NotNeeded),
                r.total_ms,
                r.written.len(),
                if r.written.len() == 1 { "" } else { "s" }
            )
        }
        Err(e) => {
            eprintln!("error: {e}");
            if let Some(html) = &run.html {
                write_html(html, Some(&p), None, run, Some(format!("error: {e}")), Some(1), subtitle);
            }
            format!("[{}] run {n}{why}: failed; fix the cause and save", now_hms())
        }
    };
    if let Some(cache) = options.cache.as_ref().filter(|c| c.root().is_dir()) {
        if let Err(e) = cache.evict() {
            eprintln!("warning: cache pruning: {e}");
        }
    }
    let mut files = vec![absolute(&run.graph.graph)];
    files.extend(p.input_files().iter().map(|f| absolute(f)));
    (files, line)
}

/// Blocks until one of `files` changes, then until `quiet` has passed without another event;
/// returns the changed files, or `None` on Ctrl-C (or when the watcher is gone).
fn wait_for_change(rx: &Receiver<Message>, files: &[PathBuf], quiet: Duration) -> Option<Vec<PathBuf>> {
    let relevant = |paths: Vec<PathBuf>| -> Vec<PathBuf> { paths.into_iter().filter(|p| files.contains(p)).collect() };
    let mut changed: Vec<PathBuf> = loop {
        match rx.recv().ok()? {
            Message::Stop => return None,
            Message::Files(paths) => {
                let hit = relevant(paths);
                if !hit.is_empty() {
                    break hit;
                }
            }
        }
    };
    loop {
        match rx.recv_timeout(quiet) {
            Ok(Message::Stop) => return None,
            Ok(Message::Files(paths)) => changed.extend(relevant(paths)),
            Err(RecvTimeoutError::Timeout) => break,
            Err(RecvTimeoutError::Disconnected) => return None,
        }
    }
    changed.sort();
    changed.dedup();
    Some(changed)
}

/// Whether an event may have changed a file's content: created, written, renamed or removed (not
/// opened, read or closed after reading, nor a metadata change such as an access time).
fn is_change(kind: &EventKind) -> bool {
    match kind {
        EventKind::Create(_) | EventKind::Remove(_) | EventKind::Any => true,
        EventKind::Modify(m) => !matches!(m, ModifyKind::Metadata(_)),
        EventKind::Access(a) => matches!(a, AccessKind::Close(AccessMode::Write)),
        EventKind::Other => false,
    }
}

fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}
