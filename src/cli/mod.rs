//! The command line, as a library: [`main_with`] runs the whole `hdrflow` command line (`run`,
//! `plan`, `batch`, `watch`, `dot`, `ops`, `cache`, every option) over any registry, so a crate
//! that adds its own operators gets the complete tool with one call (see
//! `examples/custom_operator.rs`); [`main_with_extra`] adds a binary's own subcommands beside
//! them ([`ExtraCommands`]: the `hdrflow` binary's `bench`).
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

mod bake;
mod batch;
mod batch_progress;
mod cache;
mod op_text;
mod ops;
mod ops_markdown;
mod pipeline;
mod plan;
mod progress;
mod python;
mod run;
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

use clap::{Parser, Subcommand};

use crate::engine::cache::PersistPolicy;
use crate::engine::registry::Registry;
use cache::CacheAction;
use pipeline::load_or_message;
use pipeline::{load, GraphArgs};
use run::{cache_of, write_html, write_report, RunArgs};

/// Subcommands a binary adds to the library's (`hdrflow bench`, which lives in the binary): a
/// clap `Subcommand` (derived on an enum), listed in `--help`, completions and the manual page
/// after `dot`, and run by [`ExtraCommands::run`].
pub trait ExtraCommands: Subcommand {
    /// Runs the parsed command; `registry` is the one the command line was started with.
    fn run(self, registry: &Registry) -> ExitCode;
}

/// No extra subcommand: the library's command line alone ([`main`], [`main_with`], [`main_from`]).
pub enum NoExtraCommands {}

impl clap::FromArgMatches for NoExtraCommands {
    fn from_arg_matches(_: &clap::ArgMatches) -> Result<Self, clap::Error> {
        Err(clap::Error::new(clap::error::ErrorKind::InvalidSubcommand))
    }

    fn update_from_arg_matches(&mut self, _: &clap::ArgMatches) -> Result<(), clap::Error> {
        match *self {}
    }
}

impl Subcommand for NoExtraCommands {
    fn augment_subcommands(cmd: clap::Command) -> clap::Command {
        cmd
    }

    fn augment_subcommands_for_update(cmd: clap::Command) -> clap::Command {
        cmd
    }

    fn has_subcommand(_: &str) -> bool {
        false
    }
}

impl ExtraCommands for NoExtraCommands {
    fn run(self, _: &Registry) -> ExitCode {
        match self {}
    }
}

#[derive(Parser)]
#[command(name = "hdrflow", version, about = "A node-graph engine for HDR image processing", long_about = None)]
struct Cli<E: ExtraCommands> {
    #[command(subcommand)]
    command: Command<E>,
    /// Register the Python operators (`@hdrflow.operator`) this file defines, then run the
    /// command with them (needs the hdrflow Python package; interpreter: $HDRFLOW_PYTHON, else python3)
    // Taken out of the arguments before they are parsed (`python::take_python_flag`): declared
    // here for `--help` and completions only.
    #[arg(long, global = true, value_name = "FILE")]
    python: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command<E: ExtraCommands> {
    /// Validate a pipeline file, then evaluate the nodes its targets need.
    Run(RunArgs),
    /// Show what a run would do per node: compute, cached, or not needed.
    Plan(RunArgs),
    /// Bake image-based lighting for an engine (babylon, bevy, filament, gltf, khronos, playcanvas,
    /// three): exactly the files it loads, and a README.txt with the code that loads them.
    Bake(bake::BakeArgs),
    /// Run a pipeline over a library of maps and parameter sweeps, one output folder per item.
    Batch(batch::BatchArgs),
    /// Run a pipeline, then rerun it whenever its file or a file it reads changes.
    Watch(watch::WatchArgs),
    /// Print the pipeline as a Graphviz DOT graph.
    Dot(GraphArgs),
    /// The binary's own subcommands (`bench`), listed here so that `--help` keeps its order.
    #[command(flatten)]
    Extra(E),
    /// List every operator with its ports, fields, types, defaults and docs, then the value types.
    Ops {
        /// Show only this operator.
        name: Option<String>,
        /// Write the reference as Markdown instead: DIR/<Name>.md per operator and DIR/index.md
        /// (the book's docs/src/reference/operators/).
        #[arg(long, value_name = "DIR", conflicts_with = "name")]
        markdown: Option<PathBuf>,
    },
    /// Inspect or trim the cache: stats, prune, clear.
    Cache {
        #[command(subcommand)]
        action: CacheAction,
        /// Cache folder (default: $HDRFLOW_CACHE_DIR, $XDG_CACHE_HOME/hdrflow or ~/.cache/hdrflow).
        #[arg(long, global = true)]
        cache_dir: Option<PathBuf>,
    },
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) to stdout, or
    /// write it with `-o FILE`: `hdrflow completions bash -o
    /// ~/.local/share/bash-completion/completions/hdrflow`.
    Completions {
        shell: clap_complete::Shell,
        /// Write the script to FILE instead of stdout, creating its folder.
        #[arg(long, short, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// Print the manual page (roff) to stdout, or write it with `-o FILE`: `hdrflow man -o
    /// ~/.local/share/man/man1/hdrflow.1`.
    Man {
        /// Write the page to FILE instead of stdout, creating its folder.
        #[arg(long, short, value_name = "FILE")]
        output: Option<PathBuf>,
    },
}

/// A generated file (completions, the manual) to stdout, or to `output` with its folder created
/// (a shell's completion folder or `man1` often does not exist yet, and `>` would not make it).
fn emit(bytes: &[u8], output: Option<&std::path::Path>) -> ExitCode {
    let Some(path) = output else {
        use std::io::Write as _;
        if let Err(e) = std::io::stdout().lock().write_all(bytes) {
            stdout_failed(e);
        }
        return ExitCode::SUCCESS;
    };
    match crate::engine::cache::store::write_atomic(path, bytes) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: writing {}: {e}", path.display());
            ExitCode::from(1)
        }
    }
}

/// The library's `hdrflow` command line over the built-in operators (the `hdrflow` binary adds
/// its `bench` with [`main_with_extra`]).
pub fn main() -> ExitCode {
    main_with(crate::ops::builtin_registry())
}

/// The complete `hdrflow` command line over `registry` (the built-ins plus a user's operators
/// and value types), reading the process's arguments.
pub fn main_with(registry: Registry) -> ExitCode {
    main_with_extra::<NoExtraCommands>(registry)
}

/// [`main_with`] with explicit arguments (the first is the program name).
pub fn main_from<I, T>(registry: Registry, args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    main_from_with_extra::<NoExtraCommands, _, _>(registry, args)
}

/// [`main_with`] plus the subcommands `E` (the `hdrflow` binary passes its `bench`).
pub fn main_with_extra<E: ExtraCommands>(registry: Registry) -> ExitCode {
    // The process's allocator policy, set before any thread starts (see `memory`).
    crate::memory::fix_mmap_threshold();
    main_from_with_extra::<E, _, _>(registry, std::env::args_os())
}

/// [`main_with_extra`] with explicit arguments (the first is the program name).
pub fn main_from_with_extra<E, I, T>(registry: Registry, args: I) -> ExitCode
where
    E: ExtraCommands,
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    // A bad HDRFLOW_CPU is reported before any work (the kernels would ignore it).
    if let Err(e) = crate::cpu::init() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let args: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
    if let (Some(file), rest) = python::take_python_flag(args.clone()) {
        return python::hand_over(file, rest);
    }
    let cli = match Cli::<E>::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match cli.command {
        Command::Ops { markdown: Some(dir), .. } => ops_markdown::markdown(&registry, &dir),
        Command::Ops { name, markdown: None } => ops::ops(&registry, name.as_deref()),
        Command::Dot(args) => match load(&registry, &args) {
            Ok(p) => {
                out!("{}", p.to_dot());
                ExitCode::SUCCESS
            }
            Err(code) => code,
        },
        Command::Plan(args) => plan::plan(&registry, &args),
        Command::Cache { action, cache_dir } => cache::cache_command(action, cache_dir),
        Command::Completions { shell, output } => {
            let mut cmd = <Cli<E> as clap::CommandFactory>::command();
            let mut out = Vec::new();
            clap_complete::generate(shell, &mut cmd, "hdrflow", &mut out);
            emit(&out, output.as_deref())
        }
        Command::Man { output } => {
            let cmd = <Cli<E> as clap::CommandFactory>::command();
            let mut out = Vec::new();
            if let Err(e) = clap_mangen::Man::new(cmd).render(&mut out) {
                eprintln!("error: rendering the manual: {e}");
                return ExitCode::from(1);
            }
            emit(&out, output.as_deref())
        }
        Command::Extra(extra) => extra.run(&registry),
        Command::Run(args) => run::run(&registry, &args),
        Command::Bake(args) => bake::bake(&registry, &args),
        Command::Batch(args) => batch::batch(&registry, &args),
        Command::Watch(args) => watch::watch(&registry, &args),
    }
}

/// The wall-clock time of day (UTC), `HH:MM:SS`, for summaries and pages.
pub(crate) fn now_hms() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    format!("{:02}:{:02}:{:02} UTC", secs / 3600 % 24, secs / 60 % 60, secs % 60)
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

/// What tests of each command's argument errors share.
#[cfg(test)]
pub(crate) mod testing {
    use clap::error::ErrorKind;
    use clap::Parser;

    /// The kind of error clap gives for `hdrflow ARGS...`, and its message.
    pub fn parse_error(args: &[&str]) -> (ErrorKind, String) {
        match super::Cli::<super::NoExtraCommands>::try_parse_from(
            std::iter::once("hdrflow").chain(args.iter().copied()),
        ) {
            Ok(_) => panic!("{args:?} parsed"),
            Err(e) => (e.kind(), e.to_string()),
        }
    }

    /// The exit code of `hdrflow ARGS...` over the built-in operators.
    pub fn exit_code(args: &[&str]) -> std::process::ExitCode {
        super::main_from(crate::ops::builtin_registry(), std::iter::once("hdrflow").chain(args.iter().copied()))
    }
}
