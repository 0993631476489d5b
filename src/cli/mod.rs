//! The command line, as a library: [`main_with`] runs the whole `hdrflow` command line (`run`,
//! `plan`, `dot`, `ops`, `bench`, every option) over any registry, so a crate that adds its own
//! operators gets the complete tool with one call (see `examples/custom_operator.rs`).
//! Arguments and reporting only; the work is in the library. Exit codes: 0 success, 1 a run
//! error, 2 a usage or pipeline-file error.

/// `println!` to stdout that ends the process quietly when the reader has gone away
/// (`hdrflow ops | head`), where `println!` would panic on the broken pipe.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout().lock(), $($arg)*) {
            $crate::cli::stdout_failed(e);
        }
    }};
}

/// `print!` with the same broken-pipe handling as `outln!`.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = write!(std::io::stdout().lock(), $($arg)*) {
            $crate::cli::stdout_failed(e);
        }
    }};
}

mod batch;
mod progress;
mod python;
mod slurm;
mod watch;

/// A closed pipe ends the program successfully; any other write error is reported.
pub(crate) fn stdout_failed(e: std::io::Error) -> ! {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    eprintln!("error: writing to stdout: {e}");
    std::process::exit(1);
}

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use crate::engine::cache::store::DEFAULT_LIMIT_BYTES;
use crate::engine::cache::{CacheStore, Persist, PersistPolicy};
use crate::engine::graph::{Override, Pipeline};
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions};

#[derive(Parser)]
#[command(name = "hdrflow", version, about = "A node-graph engine for HDR image processing", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Register the Python operators (`@hdrflow.operator`) this file defines, then run the
    /// command with them (needs the hdrflow Python package; interpreter: $HDRFLOW_PYTHON, else python3)
    // Taken out of the arguments before they are parsed (`python::take_python_flag`): declared
    // here for `--help` and completions only.
    #[arg(long, global = true, value_name = "FILE")]
    python: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Validate a pipeline file, then evaluate the nodes its targets need.
    Run(RunArgs),
    /// Show what a run would do per node: compute, cached, or not needed.
    Plan(RunArgs),
    /// Run a pipeline over a library of maps and parameter sweeps, one output folder per item.
    Batch(batch::BatchArgs),
    /// Run a pipeline, then rerun it whenever its file or a file it reads changes.
    Watch(watch::WatchArgs),
    /// Print the pipeline as a Graphviz DOT graph.
    Dot(GraphArgs),
    /// Benchmark run time against error for every relighting strategy and the peers.
    Bench(BenchArgs),
    /// List every operator with its ports, fields, types, defaults and docs, then the value types.
    Ops {
        /// Show only this operator.
        name: Option<String>,
    },
    /// Inspect or trim the cache: stats, prune, clear.
    Cache {
        #[command(subcommand)]
        action: CacheAction,
        /// Cache folder (default: $HDRFLOW_CACHE_DIR, $XDG_CACHE_HOME/hdrflow or ~/.cache/hdrflow).
        #[arg(long, global = true)]
        cache_dir: Option<PathBuf>,
    },
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) to stdout.
    Completions { shell: clap_complete::Shell },
    /// Print the manual page (roff) to stdout: `hdrflow man > hdrflow.1`.
    Man,
}

#[derive(Subcommand)]
enum CacheAction {
    /// Entries, bytes, live runs and leftover temporary files.
    Stats,
    /// Remove least-recently-used entries down to a size; entries in use by live runs stay.
    Prune {
        /// The size to prune down to, in MiB.
        #[arg(long, default_value_t = DEFAULT_LIMIT_BYTES >> 20)]
        max_mb: u64,
    },
    /// Remove every entry not in use by a live run.
    Clear,
}

#[derive(Args)]
struct BenchArgs {
    /// Output folder for results.csv, summary.md and the charts.
    #[arg(long, default_value = "bench/out")]
    out: PathBuf,
    /// Folder of real environment maps (Grace Cathedral, the park, the two interiors); maps
    /// that are missing are skipped with a message.
    #[arg(long, default_value = "../shared/data/envmaps")]
    data: PathBuf,
    /// Sample counts (per image for shared samples, per pixel for per-pixel strategies).
    #[arg(long, value_delimiter = ',', default_value = "16,64,256,1024,4096")]
    counts: Vec<usize>,
    /// Sphere image size in pixels.
    #[arg(long, default_value_t = 128)]
    size: usize,
    /// Timed repetitions per point (after one warm-up run, on the first seed); the median is
    /// reported.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Independent seeds per stochastic point (1, 2, ..., N; scrambles for Sobol and Halton):
    /// each error is their mean, with a 95% confidence interval when N >= 2.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..))]
    seeds: u64,
    /// Only these maps (names: sky, grace, park, fagans, studio).
    #[arg(long, value_delimiter = ',')]
    maps: Vec<String>,
    /// Folder with the peers' scripts; they run when their Python dependencies are present.
    #[arg(long, default_value = "bench/peers")]
    peers: PathBuf,
    /// Do not run the peers.
    #[arg(long)]
    no_peers: bool,
    /// A quick run: counts 16,64,256, 3 repeats, 64x64 sphere, no peers, no targets (still
    /// --seeds seeds, 8 by default: 35 s to a minute on 2 cores).
    #[arg(long)]
    quick: bool,
    /// Measure only the point targets (relight speed, BuildCdf, decoding, the seed graph).
    #[arg(long)]
    targets_only: bool,
    /// Redraw the charts from this results.csv (into --out) without measuring anything.
    #[arg(long, value_name = "RESULTS_CSV")]
    replot: Option<PathBuf>,
    /// Measure GlossySphere's strategies and SunExtract instead (glossy.csv, glossy.md).
    #[arg(long)]
    glossy: bool,
    /// --glossy: the sphere's size in pixels (its exact reference costs pixels x texels).
    #[arg(long, default_value_t = 64)]
    glossy_size: usize,
    /// --glossy: samples per pixel.
    #[arg(long, value_delimiter = ',', default_value = "4,16,64,256")]
    glossy_spp: Vec<usize>,
    /// --glossy: Phong exponents.
    #[arg(long, value_delimiter = ',', default_value = "10,200")]
    exponents: Vec<f64>,
}

#[derive(Args)]
struct GraphArgs {
    /// The pipeline file (RON).
    graph: PathBuf,
    /// Override one field: NODE.FIELD=RON_VALUE (repeatable), e.g. env.path="../x.exr".
    #[arg(long = "set", value_name = "NODE.FIELD=VALUE")]
    set: Vec<String>,
}

#[derive(Args)]
struct RunArgs {
    #[command(flatten)]
    graph: GraphArgs,
    /// Output folder for Save nodes.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Evaluate only these nodes and what they need (repeatable). Default: every Save node and
    /// every node nothing consumes.
    #[arg(long = "target", value_name = "NODE")]
    targets: Vec<String>,
    /// Cache folder (default: $HDRFLOW_CACHE_DIR, $XDG_CACHE_HOME/hdrflow or ~/.cache/hdrflow).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Compute everything; neither read nor write the cache.
    #[arg(long)]
    no_cache: bool,
    /// At most this many MiB of new cache entries from this run (results past it are not
    /// stored). Other pipelines' entries are never touched by it; the folder as a whole is
    /// pruned to $HDRFLOW_CACHE_MAX_MB (default 4096) after a run, sparing live runs' entries.
    #[arg(long, default_value_t = DEFAULT_LIMIT_BYTES >> 20)]
    cache_limit_mb: u64,
    /// Which computed results go into the cache: `auto` keeps the run's targets, small results
    /// and whatever is slower to recompute than to read back (not huge cheap intermediates);
    /// `all` keeps everything.
    #[arg(long, value_enum, default_value_t = PersistArg::Auto)]
    persist: PersistArg,
    /// Worker threads; 0 or absent: one per core.
    #[arg(long)]
    jobs: Option<usize>,
    /// Write the run report as JSON to this file.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Print only errors and warnings.
    #[arg(long, short, conflicts_with = "verbose")]
    quiet: bool,
    /// Also print one line per node as it finishes, and the per-node table at the end.
    #[arg(long, short)]
    verbose: bool,
    /// Print this node's value after the run (repeatable); metrics and other small targets are
    /// printed without asking.
    #[arg(long = "print", value_name = "NODE")]
    print: Vec<String>,
    /// Print the run report as JSON on stdout (for scripts) instead of the summary.
    #[arg(long)]
    json: bool,
    /// Write a self-contained HTML page of the run to FILE: the graph coloured by status,
    /// thumbnails of every image output, metrics, each node's time and cache status, and the
    /// timeline of the parallel schedule.
    #[arg(long, value_name = "FILE")]
    html: Option<PathBuf>,
}

/// The `hdrflow` command line over the built-in operators.
pub fn main() -> ExitCode {
    main_with(crate::ops::builtin_registry())
}

/// The complete `hdrflow` command line over `registry` (the built-ins plus a user's operators
/// and value types), reading the process's arguments.
pub fn main_with(registry: Registry) -> ExitCode {
    main_from(registry, std::env::args_os())
}

/// [`main_with`] with explicit arguments (the first is the program name).
pub fn main_from<I, T>(registry: Registry, args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
    if let (Some(file), rest) = python::take_python_flag(args.clone()) {
        return python::hand_over(file, rest);
    }
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match cli.command {
        Command::Ops { name } => ops(&registry, name.as_deref()),
        Command::Dot(args) => match load(&registry, &args) {
            Ok(p) => {
                out!("{}", p.to_dot());
                ExitCode::SUCCESS
            }
            Err(code) => code,
        },
        Command::Plan(args) => plan(&registry, &args),
        Command::Cache { action, cache_dir } => cache_command(action, cache_dir),
        Command::Completions { shell } => {
            let mut cmd = <Cli as clap::CommandFactory>::command();
            clap_complete::generate(shell, &mut cmd, "hdrflow", &mut std::io::stdout());
            ExitCode::SUCCESS
        }
        Command::Man => {
            let cmd = <Cli as clap::CommandFactory>::command();
            let mut out = Vec::new();
            if let Err(e) = clap_mangen::Man::new(cmd).render(&mut out) {
                eprintln!("error: rendering the manual: {e}");
                return ExitCode::from(1);
            }
            out!("{}", String::from_utf8_lossy(&out));
            ExitCode::SUCCESS
        }
        Command::Bench(args) => bench(&args),
        Command::Run(args) => run(&registry, &args),
        Command::Batch(args) => batch::batch(&registry, &args),
        Command::Watch(args) => watch::watch(&registry, &args),
    }
}

fn load(registry: &Registry, args: &GraphArgs) -> Result<Pipeline, ExitCode> {
    load_or_message(registry, args).map_err(|message| {
        eprint!("{message}");
        ExitCode::from(2)
    })
}

/// The pipeline with its `--set` overrides, or every error as the lines to print (exit code 2).
fn load_or_message(registry: &Registry, args: &GraphArgs) -> Result<Pipeline, String> {
    let mut overrides = Vec::new();
    for s in &args.set {
        overrides.push(Override::parse(s).map_err(|e| format!("error: {e}\n"))?);
    }
    Pipeline::load(&args.graph, registry, &overrides).map_err(|errors| {
        let mut message = String::new();
        for e in &errors.0 {
            message.push_str(&format!("error: {e}\n"));
        }
        message.push_str(&format!(
            "{} error{} in {}; nothing was run\n",
            errors.0.len(),
            if errors.0.len() == 1 { "" } else { "s" },
            args.graph.display()
        ));
        message
    })
}

/// Writes the HTML page of a run (`--html`); a failure to write is a warning, not the run's.
fn write_html(
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

/// The wall-clock time of day (UTC), `HH:MM:SS`, for summaries and pages.
pub(crate) fn now_hms() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    format!("{:02}:{:02}:{:02} UTC", secs / 3600 % 24, secs / 60 % 60, secs % 60)
}

fn cache_of(args: &RunArgs) -> Option<CacheStore> {
    (!args.no_cache).then(|| {
        CacheStore::new(args.cache_dir.clone().unwrap_or_else(CacheStore::default_dir), args.cache_limit_mb << 20)
            .with_policy(args.persist.into())
    })
}

/// `--persist`: which computed results a run stores (see `engine::cache::policy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum PersistArg {
    Auto,
    All,
}

impl From<PersistArg> for PersistPolicy {
    fn from(a: PersistArg) -> Self {
        match a {
            PersistArg::Auto => PersistPolicy::Auto,
            PersistArg::All => PersistPolicy::All,
        }
    }
}

fn plan(registry: &Registry, args: &RunArgs) -> ExitCode {
    let p = match load(registry, &args.graph) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let cache = cache_of(args);
    match scheduler::plan(&p, &args.targets, cache.as_ref()) {
        Ok(plan) => {
            // Columns as wide as their longest entry, so long node names do not shift the rest.
            let name_w = p.nodes.iter().map(|n| n.name.chars().count()).chain([4]).max().unwrap_or(4);
            let op_w = p.nodes.iter().map(|n| n.spec.name.len()).chain([8]).max().unwrap_or(8);
            outln!("{:<name_w$} {:<op_w$} {:<11} {:<16} outputs", "node", "operator", "plan", "key");
            for (i, n) in p.nodes.iter().enumerate() {
                let key = plan.keys[i].map(|k| crate::engine::cache::key_hex(&k)[..16].to_string()).unwrap_or_default();
                let ports: Vec<String> = n.ports.iter().map(|p| format!("{}: {}", p.name, p.ty)).collect();
                outln!(
                    "{:<name_w$} {:<op_w$} {:<11} {:<16} {}",
                    n.name,
                    n.spec.name,
                    plan.status[i].word(),
                    key,
                    ports.join(", ")
                );
            }
            let count = |st: NodeStatus| plan.status.iter().filter(|s| **s == st).count();
            outln!(
                "{} nodes: {} computed, {} cached, {} not needed (planned; nothing was run)",
                p.nodes.len(),
                count(NodeStatus::Computed),
                count(NodeStatus::Cached),
                count(NodeStatus::NotNeeded)
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(run_error_code(&e))
        }
    }
}

fn run_error_code(e: &crate::engine::error::RunError) -> u8 {
    match e {
        crate::engine::error::RunError::UnknownTarget(..) => 2,
        _ => 1,
    }
}

fn run(registry: &Registry, args: &RunArgs) -> ExitCode {
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

fn cache_command(action: CacheAction, dir: Option<PathBuf>) -> ExitCode {
    let dir = dir.unwrap_or_else(CacheStore::default_dir);
    let store = CacheStore::new(&dir, 0);
    let result = match action {
        CacheAction::Stats => store.stats().map(|s| {
            outln!(
                "{}: {} entries, {:.1} MiB; {} live run{}; {} leftover temporary file{}",
                dir.display(),
                s.entries,
                s.bytes as f64 / (1 << 20) as f64,
                s.live_runs,
                if s.live_runs == 1 { "" } else { "s" },
                s.temporaries,
                if s.temporaries == 1 { "" } else { "s" }
            );
        }),
        CacheAction::Prune { max_mb } => store.prune(max_mb << 20).map(|r| report_removal(&dir, r)),
        CacheAction::Clear => store.clear().map(|r| report_removal(&dir, r)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn report_removal(dir: &std::path::Path, r: crate::engine::cache::store::EvictionReport) {
    let kept = r.entries - r.removed;
    outln!(
        "{}: removed {} of {} entries ({:.1} MiB -> {:.1} MiB){}",
        dir.display(),
        r.removed,
        r.entries,
        r.bytes_before as f64 / (1 << 20) as f64,
        r.bytes_after as f64 / (1 << 20) as f64,
        if kept > 0 && r.bytes_after > 0 {
            format!("; {kept} kept (in use by live runs, or within the size)")
        } else {
            String::new()
        }
    );
}

fn ops(registry: &Registry, name: Option<&str>) -> ExitCode {
    let all = registry.all();
    let selected: Vec<_> = all.iter().filter(|s| name.is_none_or(|n| s.name.eq_ignore_ascii_case(n))).collect();
    if selected.is_empty() {
        eprintln!("error: no operator {:?} (operators: {})", name.unwrap_or(""), registry.names().join(", "));
        return ExitCode::from(2);
    }
    let mut category = "";
    for spec in selected {
        if spec.category != category {
            category = spec.category;
            outln!("== {category} ==");
        }
        outln!("{} (v{})", spec.name, spec.version);
        outln!("    {}", spec.doc);
        outln!(
            "    cache: {}",
            match spec.persist {
                Persist::Measured => "a large result is stored when slower to recompute than to read back",
                Persist::Always => "every result is stored",
                Persist::IfSmall => "a large result is stored only as a target (one cheap pass per byte)",
            }
        );
        for port in &spec.outputs {
            outln!("    -> {:<12} {:<40} {}", port.name, port.ty.describe(), port.doc);
        }
        if let Some(open) = &spec.open_ports {
            outln!("    -> {:<12} {:<40} {}", "<any>", open.ty.to_string(), open.doc);
        }
        for f in &spec.fields {
            outln!("    {:<15} {:<40} {:<22} {}", f.name, f.kind.describe(), f.describe_default(), f.doc);
        }
        if spec.name == "LoadHdr" {
            outln!("    built-in maps (path: \"builtin:NAME\"):");
            for (n, doc) in crate::formats::builtin::BUILTINS {
                outln!("      {n:<10} {doc}");
            }
        }
        outln!();
    }
    if name.is_none() {
        outln!("== value types ==");
        for t in registry.value_types() {
            let saves = t.spec().save_extensions;
            let saved = if saves.is_empty() {
                String::new()
            } else {
                format!(" (Save: {})", saves.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(" "))
            };
            outln!("    {:<14} {}{saved}", t.name(), t.spec().doc);
        }
    }
    ExitCode::SUCCESS
}

fn bench(args: &BenchArgs) -> ExitCode {
    use crate::bench::{BenchConfig, MapSpec};
    let candidates = [
        ("sky", "builtin:sky".to_string(), false),
        ("grace", args.data.join("grace_latlong.exr").display().to_string(), true),
        ("park", args.data.join("rooitou_park_1k.hdr").display().to_string(), false),
        ("fagans", args.data.join("st_fagans_interior_1k.hdr").display().to_string(), false),
        ("studio", args.data.join("studio_small_03_1k.hdr").display().to_string(), false),
    ];
    let mut maps = Vec::new();
    for (name, source, flip) in candidates {
        if !args.maps.is_empty() && !args.maps.iter().any(|m| m == name) {
            continue;
        }
        if !source.starts_with("builtin:") && !std::path::Path::new(&source).is_file() {
            eprintln!("SKIPPED map {name}: {source} not found");
            continue;
        }
        maps.push(MapSpec { name: name.to_string(), source, flip_vertical: flip });
    }
    if maps.is_empty() {
        eprintln!("error: no map to benchmark");
        return ExitCode::from(2);
    }
    if args.glossy {
        let config = crate::bench::glossy::GlossyBenchConfig {
            maps,
            spp: args.glossy_spp.clone(),
            exponents: args.exponents.clone(),
            size: args.glossy_size,
            repeats: if args.quick { 1 } else { args.repeats },
            seed: 1,
            out_dir: args.out.clone(),
        };
        eprintln!("hdrflow bench --glossy on {} threads", rayon::current_num_threads());
        return match crate::bench::glossy::run(&config, &|line| eprintln!("{line}")) {
            Ok(rows) => {
                outln!("{} points; wrote {}/glossy.csv and glossy.md", rows.len(), args.out.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(1)
            }
        };
    }
    let config = BenchConfig {
        maps,
        counts: if args.quick { vec![16, 64, 256] } else { args.counts.clone() },
        size: if args.quick { 64 } else { args.size },
        repeats: if args.quick { 3 } else { args.repeats },
        albedo: 0.8,
        view: (90.0, 90.0),
        seed: 1,
        seeds: args.seeds as usize,
        out_dir: args.out.clone(),
        peers_dir: (!args.no_peers && !args.quick).then(|| args.peers.clone()),
    };
    if let Some(csv) = &args.replot {
        return match crate::bench::replot(&config, csv) {
            Ok(n) => {
                outln!("redrew {n} charts into {}", args.out.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(1)
            }
        };
    }
    eprintln!(
        "hdrflow bench on {} threads; {} seed{} per stochastic point (seeds {} to {}){}",
        rayon::current_num_threads(),
        config.seeds,
        if config.seeds == 1 { "" } else { "s" },
        config.seed,
        config.seed + config.seeds as u64 - 1,
        if args.quick { "; --quick: counts 16,64,256, 64x64 sphere, 3 repeats, no peers, no targets" } else { "" }
    );
    if !args.quick {
        let peers = (!args.no_peers).then_some(args.peers.as_path());
        match crate::bench::targets::measure(&args.data, peers, config.repeats, &|line| eprintln!("{line}")) {
            Ok(targets) => {
                let md = crate::bench::targets::markdown(&targets);
                out!("{md}");
                let path = args.out.join("targets.md");
                if let Err(e) = std::fs::create_dir_all(&args.out)
                    .and_then(|_| crate::engine::cache::store::write_atomic(&path, md.as_bytes()))
                {
                    eprintln!("error: writing {}: {e}", path.display());
                    return ExitCode::from(1);
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        }
        if args.targets_only {
            return ExitCode::SUCCESS;
        }
    }
    match crate::bench::run(&config, &|line| eprintln!("{line}")) {
        Ok(rows) => {
            outln!(
                "{} points; wrote {}/results.csv, summary.md and time_error_*.png/.svg",
                rows.len(),
                args.out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
