//! Replays the corpora that cargo-fuzz grew (`fuzz/regressions/<target>/`, minimised with
//! libFuzzer's `-merge=1` and thinned to 300 small inputs per target) through the readers and
//! the pipeline parser: each input must give `Ok` or `Err`, never a panic. A crash that a
//! fuzzer finds goes into the same folders, so it stays fixed.
//!
//! To grow them: `cd fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run rgbe -s none --release regressions/rgbe`.

use std::path::{Path, PathBuf};

use hdrflow::Pipeline;

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
    assert!(panics.is_empty(), "{target}: {} of {} inputs panicked: {panics:?}", panics.len(), files.len());
}

#[test]
fn rgbe_corpus_never_panics() {
    replay("rgbe", |b| {
        let _ = hdrflow::formats::rgbe::decode(b);
    });
}

#[test]
fn pfm_corpus_never_panics() {
    replay("pfm", |b| {
        let _ = hdrflow::formats::pfm::decode(b);
    });
}

#[test]
fn exr_corpus_never_panics() {
    replay("exr", |b| {
        let _ = hdrflow::formats::exr::decode(b);
    });
}

#[test]
fn pipeline_corpus_never_panics() {
    // The registry holds operators' closures; a panic leaves nothing of it half-updated.
    let registry = std::panic::AssertUnwindSafe(hdrflow::builtin_registry());
    replay("pipeline", |b| {
        let _ = Pipeline::parse(&String::from_utf8_lossy(b), "fuzz.ron", Path::new("."), &registry, &[]);
    });
}
