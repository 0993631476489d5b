//! What is worth keeping in the persistent cache.
//!
//! Storing everything costs disk without paying back: one seed run on an 8192x4096 map wrote
//! hundreds of times its outputs' bytes in entries (docs/src/benchmarks/batch.md, "Cache bytes per item"),
//! mostly full-size images that one pass over memory recomputes faster than a disk reads them
//! back. The rule, applied to each
//! computed node when it finishes:
//!
//! 1. Under `PersistPolicy::All` every result is stored (what a user inspecting intermediates
//!    wants, and the behaviour before this policy existed).
//! 2. A run's targets are always stored (the outputs of a run, a batch's shared nodes, what
//!    `--target` asked for), and so is any result of at most [`SMALL_ENTRY_BYTES`]: metrics,
//!    curves, sample sets and small images cost nothing to keep.
//! 3. Otherwise the operator's [`Persist`] class decides: `Always` (costly per byte: exact
//!    references, renders), `IfSmall` (one cheap pass per output byte: constants, exposure,
//!    channel shuffles; never worth a large entry), or `Measured`: stored when recomputing it
//!    would take longer than reading it back, `recompute_ms >= bytes / RELOAD_BYTES_PER_MS`,
//!    where `recompute_ms` is the node's own compute time plus that of every input chain not
//!    stored either (what a later run would have to redo to get the value back).
//!
//! The decision only changes which entries exist, never a key or a stored byte, so caches stay
//! portable between machines even though the timing behind `Measured` is not.

/// How an operator's results weigh in the store decision (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Persist {
    /// Stored when small or slower to recompute than to read back.
    #[default]
    Measured,
    /// Always stored: computing it costs far more than reading it.
    Always,
    /// Stored only when small: recomputing is one cheap pass per output byte.
    IfSmall,
}

/// A run's store policy (`--persist`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PersistPolicy {
    /// The rule of the module documentation.
    #[default]
    Auto,
    /// Store every computed result.
    All,
}

/// Results up to this size are always stored: 1 MiB.
pub const SMALL_ENTRY_BYTES: u64 = 1 << 20;

/// Reading an entry back (file read, BLAKE3 check, decode into a value), in bytes per
/// millisecond: 500 MB/s, a little below what a cached load of a large distribution reached on
/// this project's busy 2-core machine (docs/src/benchmarks/batch.md, "Cache bytes per item"), so that a value
/// is dropped only when recomputing it is the cheaper way back.
pub const RELOAD_BYTES_PER_MS: f64 = 500_000.0;

/// Whether a computed node's results (`bytes` in all) go into the cache.
pub fn worth_storing(policy: PersistPolicy, class: Persist, is_target: bool, recompute_ms: f64, bytes: u64) -> bool {
    if policy == PersistPolicy::All || is_target || bytes <= SMALL_ENTRY_BYTES {
        return true;
    }
    match class {
        Persist::Always => true,
        Persist::IfSmall => false,
        Persist::Measured => recompute_ms >= bytes as f64 / RELOAD_BYTES_PER_MS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BIG: u64 = 400 << 20; // an 8192x4096 RGB f32 image

    #[test]
    fn all_targets_and_small_results_are_always_stored() {
        for class in [Persist::Measured, Persist::Always, Persist::IfSmall] {
            assert!(worth_storing(PersistPolicy::All, class, false, 0.0, BIG));
            assert!(worth_storing(PersistPolicy::Auto, class, true, 0.0, BIG));
            assert!(worth_storing(PersistPolicy::Auto, class, false, 0.0, SMALL_ENTRY_BYTES));
        }
    }

    #[test]
    fn large_results_follow_their_class() {
        assert!(worth_storing(PersistPolicy::Auto, Persist::Always, false, 0.0, BIG));
        assert!(!worth_storing(PersistPolicy::Auto, Persist::IfSmall, false, 1e9, BIG));
        // 400 MiB read back at 500 MB/s: about 839 ms.
        let reload = BIG as f64 / RELOAD_BYTES_PER_MS;
        assert!((reload - 838.9).abs() < 0.1, "{reload}");
        assert!(!worth_storing(PersistPolicy::Auto, Persist::Measured, false, reload * 0.99, BIG));
        assert!(worth_storing(PersistPolicy::Auto, Persist::Measured, false, reload, BIG));
    }
}
