//! `engine::graph::Pipeline::parse` on arbitrary text (the bytes as lossy UTF-8), with the
//! built-in registry: `Ok` or `Err`, never a panic. Seed the corpus with `../graphs/*.ron`:
//! `mkdir -p corpus/pipeline && cp ../graphs/*.ron corpus/pipeline/`.
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use hdrflow::{Pipeline, Registry};
use libfuzzer_sys::fuzz_target;

fn registry() -> &'static Registry {
    static R: OnceLock<Registry> = OnceLock::new();
    R.get_or_init(hdrflow::builtin_registry)
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = Pipeline::parse(&text, "fuzz.ron", Path::new("."), registry(), &[]);
});
