//! Replays the corpora that cargo-fuzz grew (`fuzz/regressions/<target>/`, minimised with
//! libFuzzer's `-merge=1` and thinned to 300 small inputs per target) through each fuzz target's
//! own check (`fuzz/checks.rs`, the same functions the targets call): an input fails the replay
//! exactly when the fuzzer would report it, on a panic, on a malformed decoded image, or on a
//! panic of the `exr` crate that the EXR reader caught and returned as
//! `FormatError::DecoderPanicked` (an error to the user, but a bug). A crash that a fuzzer finds
//! goes into the same folders, so it stays fixed.
//!
//! To grow them: `cd fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run rgbe -s none --release regressions/rgbe`.

#[path = "../fuzz/checks.rs"]
mod checks;

use std::path::{Path, PathBuf};

fn inputs(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    files.sort();
    assert!(files.len() >= 50, "{}: only {} inputs", dir.display(), files.len());
    files
}

fn replay(target: &str, f: impl Fn(&[u8]) + std::panic::RefUnwindSafe) {
    let mut panics = Vec::new();
    let files = inputs(target);
    for path in &files {
        let bytes = std::fs::read(path).expect("readable input");
        if std::panic::catch_unwind(|| f(&bytes)).is_err() {
            panics.push(path.display().to_string());
        }
    }
    assert!(
        panics.is_empty(),
        "{target}: {} of {} inputs failed the fuzz check: {panics:?}",
        panics.len(),
        files.len()
    );
}

#[test]
fn rgbe_corpus_passes_the_fuzz_check() {
    replay("rgbe", checks::rgbe);
}

#[test]
fn pfm_corpus_passes_the_fuzz_check() {
    replay("pfm", checks::pfm);
}

#[test]
fn exr_corpus_passes_the_fuzz_check_no_caught_decoder_panic() {
    replay("exr", checks::exr);
}

#[test]
fn pipeline_corpus_passes_the_fuzz_check() {
    // The registry holds operators' closures; a panic leaves nothing of it half-updated.
    let registry = std::panic::AssertUnwindSafe(hdrflow::builtin_registry());
    replay("pipeline", |b| checks::pipeline(b, &registry));
}
