//! `hdrflow run`: validate a pipeline file, evaluate what its targets need, report (the JSON
//! report, and the HTML page that `watch` writes too), print the values asked for, and keep the
//! cache folder within its size.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::pipeline::{load, GraphArgs};
use super::{now_hms, progress, PersistArg};
use crate::engine::cache::store::DEFAULT_LIMIT_BYTES;
use crate::engine::cache::CacheStore;
use crate::engine::graph::Pipeline;
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions};

#[derive(Args)]
pub(super) struct RunArgs {
    #[command(flatten)]
    pub(super) graph: GraphArgs,
    /// Output folder for Save nodes.
    #[arg(long, default_value = "out")]
    pub(super) out: PathBuf,
    /// Evaluate only these nodes and what they need (repeatable); NODE.PORT keeps only that port's
    /// value to the end (the node's other ports go to their consumers). Default: every Save node
    /// and every node nothing consumes.
    #[arg(long = "target", value_name = "NODE")]
    pub(super) targets: Vec<String>,
    /// Cache folder (default: $HDRFLOW_CACHE_DIR, $XDG_CACHE_HOME/hdrflow or ~/.cache/hdrflow).
    #[arg(long)]
    pub(super) cache_dir: Option<PathBuf>,
    /// Compute everything; neither read nor write the cache.
    #[arg(long)]
    pub(super) no_cache: bool,
    /// At most this many MiB of new cache entries from this run (results past it are not
    /// stored). Other pipelines' entries are never touched by it; the folder as a whole is
    /// pruned to $HDRFLOW_CACHE_MAX_MB (default 4096) after a run, sparing live runs' entries.
    #[arg(long, default_value_t = DEFAULT_LIMIT_BYTES >> 20)]
    pub(super) cache_limit_mb: u64,
    /// Which computed results go into the cache: `auto` keeps the run's targets, small results
    /// and whatever is slower to recompute than to read back (not huge cheap intermediates);
    /// `all` keeps everything.
    #[arg(long, value_enum, default_value_t = PersistArg::Auto)]
    pub(super) persist: PersistArg,
    /// Worker threads; 0 or absent: one per core.
    #[arg(long)]
    pub(super) jobs: Option<usize>,
    /// Write the run report as JSON to this file.
    #[arg(long)]
    pub(super) report: Option<PathBuf>,
    /// Print only errors and warnings.
    #[arg(long, short, conflicts_with = "verbose")]
    pub(super) quiet: bool,
    /// Also print one line per node as it finishes, and the per-node table at the end.
    #[arg(long, short)]
    pub(super) verbose: bool,
    /// Print this node's value after the run (repeatable); metrics and other small targets are
    /// printed without asking.
    #[arg(long = "print", value_name = "NODE")]
    pub(super) print: Vec<String>,
    /// Print the run report as JSON on stdout (for scripts) instead of the summary.
    #[arg(long)]
    pub(super) json: bool,
    /// Write a self-contained HTML page of the run to FILE: the graph coloured by status,
    /// thumbnails of every image output, metrics, each node's time and cache status, and the
    /// timeline of the parallel schedule.
    #[arg(long, value_name = "FILE")]
    pub(super) html: Option<PathBuf>,
}

pub(super) fn cache_of(args: &RunArgs) -> Option<CacheStore> {
    (!args.no_cache).then(|| {
        CacheStore::new(args.cache_dir.clone().unwrap_or_else(CacheStore::default_dir), args.cache_limit_mb << 20)
            .with_policy(args.persist.into())
    })
}

pub(super) fn run_error_code(e: &crate::engine::error::RunError) -> u8 {
    match e {
        crate::engine::error::RunError::UnknownTarget(..) => 2,
        _ => 1,
    }
}

pub(super) fn run(registry: &Registry, args: &RunArgs) -> ExitCode {
    // A usage error, found before the pipeline is even read.
    if args.out.exists() && !args.out.is_dir() {
        eprintln!("error: --out {}: is a file; --out names the folder results are written into", args.out.display());
        return ExitCode::from(2);
    }
    let p = match load(registry, &args.graph) {
        Ok(p) => p,
        Err(code) => return code,
    };
    for name in &args.print {
        if p.target_index(name).is_none() {
            let names = p.target_names();
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            eprintln!(
                "error: --print {name:?}: no such node or port{}",
                crate::engine::graph::suggest(name, &names, "nodes")
            );
            return ExitCode::from(2);
        }
    }
    let verbosity = if args.quiet {
        progress::Verbosity::Quiet
    } else if args.verbose {
        progress::Verbosity::Verbose
    } else {
        progress::Verbosity::Normal
    };
    let observer = progress::Progress::new(verbosity);
    // Nodes to print are targets too, so that their values come back.
    let mut targets = args.targets.clone();
    if !args.print.is_empty() {
        if targets.is_empty() {
            targets = p.default_targets().into_iter().map(|i| p.nodes[i].name.clone()).collect();
        }
        targets.extend(args.print.iter().cloned());
    }
    let options = RunOptions {
        targets,
        out_dir: args.out.clone(),
        cache: cache_of(args),
        jobs: args.jobs.filter(|&j| j > 0),
        observer: &observer,
    };
    let outcome = scheduler::run(&p, &options);
    observer.finish();
    if let Some(html) = &args.html {
        let (report, error) = match &outcome {
            Ok(o) => (Some(&o.report), None),
            Err(e) => (None, Some(format!("error: {e}"))),
        };
        write_html(html, Some(&p), report, args, error, None, format!("hdrflow run, {}", now_hms()));
    }
    let outcome = match outcome {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(run_error_code(&e));
        }
    };
    let report = &outcome.report;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(report).expect("report serialises"));
    } else if !args.quiet {
        if args.verbose {
            progress::print_table(report);
        }
        outln!(
            "{} nodes: {} computed, {} cached, {} not needed; {:.1} ms; {} file{} written to {}",
            report.nodes.len(),
            report.count(NodeStatus::Computed),
            report.count(NodeStatus::Cached),
            report.count(NodeStatus::NotNeeded),
            report.total_ms,
            report.written.len(),
            if report.written.len() == 1 { "" } else { "s" },
            args.out.display()
        );
    }
    if !args.json {
        let nodes: std::collections::BTreeSet<&str> = p.nodes.iter().map(|n| n.name.as_str()).collect();
        print_values(&outcome.values, &args.print, &nodes, args.quiet);
    }
    // A cache folder the run could not use was already reported (one warning, and the run went
    // on without it): there is nothing of ours to evict there, and no second warning to give.
    if let Some(cache) = options.cache.as_ref().filter(|c| c.root().is_dir()) {
        match cache.evict() {
            Ok(r) if r.removed > 0 && args.verbose => {
                eprintln!(
                    "cache: pruned {} least-recently-used entries ({} MiB -> {} MiB)",
                    r.removed,
                    r.bytes_before >> 20,
                    r.bytes_after >> 20
                )
            }
            Ok(_) => {}
            Err(e) => eprintln!("warning: cache pruning: {e}"),
        }
    }
    if let Some(path) = &args.report {
        if let Err(e) = write_report(path, report) {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    }
    ExitCode::SUCCESS
}

/// Writes the HTML page of a run (`--html`); a failure to write is a warning, not the run's.
pub(super) fn write_html(
    path: &std::path::Path,
    p: Option<&Pipeline>,
    report: Option<&scheduler::RunReport>,
    args: &RunArgs,
    error: Option<String>,
    refresh_seconds: Option<u32>,
    subtitle: String,
) {
    let page = crate::report::html::Page {
        title: args.graph.graph.display().to_string(),
        pipeline: p,
        report,
        out_dir: &args.out,
        error,
        refresh_seconds,
        subtitle,
    };
    if let Err(e) = crate::report::html::write(path, &page) {
        eprintln!("warning: writing {}: {e}", path.display());
    }
}

/// `--report FILE`: the run report as pretty JSON, written atomically.
pub(crate) fn write_report(path: &std::path::Path, report: &scheduler::RunReport) -> Result<(), String> {
    let json = serde_json::to_string_pretty(report).expect("report serialises");
    crate::engine::cache::store::write_atomic(path, json.as_bytes())
        .map_err(|e| format!("writing report {}: {e}", path.display()))
}

/// Prints the values a user asked for with `--print` (any type, in full where the type can
/// show itself, else a one-line summary) and the small target values that show themselves
/// (metrics, curve scalars, SH coefficients; default ports only), unless quiet.
fn print_values(
    values: &std::collections::BTreeMap<String, crate::Value>,
    asked: &[String],
    nodes: &std::collections::BTreeSet<&str>,
    quiet: bool,
) {
    for (name, value) in values {
        let wanted = asked.iter().any(|a| a == name);
        if !wanted && !nodes.contains(name.as_str()) {
            continue; // another port of a target: printed when asked for
        }
        match value.display() {
            Some(text) if wanted || !quiet => {
                outln!("{name} ({}):", value.value_type());
                for line in text.lines() {
                    outln!("  {line}");
                }
            }
            None if wanted => outln!("{name}: {}", value.summary()),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use std::process::ExitCode;

    use clap::error::ErrorKind;

    use crate::cli::testing::{exit_code, parse_error};

    #[test]
    fn argument_errors_name_the_argument() {
        let (kind, msg) = parse_error(&["run", "g.ron", "--jobs", "two"]);
        assert_eq!(kind, ErrorKind::ValueValidation);
        assert!(msg.contains("--jobs"), "{msg}");
        let (kind, msg) = parse_error(&["run", "g.ron", "--persist", "some"]);
        assert_eq!(kind, ErrorKind::InvalidValue);
        assert!(msg.contains("auto") && msg.contains("all"), "the choices: {msg}");
        assert_eq!(parse_error(&["run", "g.ron", "--quiet", "--verbose"]).0, ErrorKind::ArgumentConflict);
        assert_eq!(parse_error(&["run"]).0, ErrorKind::MissingRequiredArgument);
        assert_eq!(parse_error(&["run", "g.ron", "--frobnicate"]).0, ErrorKind::UnknownArgument);
    }

    /// `--out` naming a file is a usage error (2), found before the pipeline is read; a missing
    /// pipeline file is a pipeline-file error (2).
    #[test]
    fn usage_errors_exit_2() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a-file");
        std::fs::write(&file, b"").unwrap();
        let missing = dir.path().join("missing.ron");
        let (file, missing) = (file.to_str().unwrap(), missing.to_str().unwrap());
        assert_eq!(exit_code(&["run", missing, "--out", file, "--no-cache", "-q"]), ExitCode::from(2));
        let out = dir.path().join("out");
        assert_eq!(exit_code(&["run", missing, "--out", out.to_str().unwrap(), "--no-cache", "-q"]), ExitCode::from(2));
    }
}
