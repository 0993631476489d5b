//! `hdrflow cache stats|prune|clear`: inspect or trim a cache folder.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;

use crate::engine::cache::store::DEFAULT_LIMIT_BYTES;
use crate::engine::cache::CacheStore;

#[derive(Subcommand)]
pub(super) enum CacheAction {
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

pub(super) fn cache_command(action: CacheAction, dir: Option<PathBuf>) -> ExitCode {
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

#[cfg(test)]
mod tests {
    use clap::error::ErrorKind;

    use crate::cli::testing::parse_error;

    #[test]
    fn argument_errors() {
        let (kind, msg) = parse_error(&["cache", "prune", "--max-mb", "lots"]);
        assert_eq!(kind, ErrorKind::ValueValidation);
        assert!(msg.contains("--max-mb"), "{msg}");
        assert_eq!(parse_error(&["cache", "frobnicate"]).0, ErrorKind::InvalidSubcommand);
        assert_eq!(parse_error(&["cache"]).0, ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand);
    }
}
