//! What every command that reads a pipeline file shares: its arguments (the file and `--set`),
//! loading it with every error as the lines to print, and the HTML page of a run.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::run::RunArgs;
use crate::engine::graph::{Override, Pipeline};
use crate::engine::registry::Registry;
use crate::engine::scheduler;

#[derive(Args)]
pub(super) struct GraphArgs {
    /// The pipeline file (RON).
    pub(super) graph: PathBuf,
    /// Override one field: NODE.FIELD=RON_VALUE (repeatable), e.g. env.path="../x.exr".
    #[arg(long = "set", value_name = "NODE.FIELD=VALUE")]
    pub(super) set: Vec<String>,
}

pub(super) fn load(registry: &Registry, args: &GraphArgs) -> Result<Pipeline, ExitCode> {
    load_or_message(registry, args).map_err(|message| {
        eprint!("{message}");
        ExitCode::from(2)
    })
}

/// The pipeline with its `--set` overrides, or every error as the lines to print (exit code 2).
pub(super) fn load_or_message(registry: &Registry, args: &GraphArgs) -> Result<Pipeline, String> {
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
