//! `hdrflow plan`: what a run would do per node (compute, cached, not needed), run nothing.

use std::process::ExitCode;

use super::pipeline::load;
use super::run::{cache_of, run_error_code, RunArgs};
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus};

pub(super) fn plan(registry: &Registry, args: &RunArgs) -> ExitCode {
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

#[cfg(test)]
mod tests {
    use std::process::ExitCode;

    use clap::error::ErrorKind;

    use crate::cli::testing::{exit_code, parse_error};

    #[test]
    fn argument_errors() {
        assert_eq!(parse_error(&["plan"]).0, ErrorKind::MissingRequiredArgument);
        assert_eq!(parse_error(&["plan", "g.ron", "--cache-limit-mb", "-1"]).0, ErrorKind::UnknownArgument);
        // An unknown --target is a usage error (2), with nothing run.
        let dir = tempfile::tempdir().unwrap();
        let g = dir.path().join("g.ron");
        std::fs::write(&g, r#"(nodes: { "env": LoadHdr(path: "builtin:sky") })"#).unwrap();
        assert_eq!(exit_code(&["plan", g.to_str().unwrap(), "--no-cache", "--target", "nope"]), ExitCode::from(2));
        assert_eq!(exit_code(&["plan", g.to_str().unwrap(), "--no-cache", "--target", "env"]), ExitCode::SUCCESS);
    }
}
