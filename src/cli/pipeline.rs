//! What every command that reads a pipeline file shares: its arguments (the file and `--set`),
//! and loading it with every error as the lines to print.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use crate::engine::graph::{Override, Pipeline};
use crate::engine::registry::Registry;

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
