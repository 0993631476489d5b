//! `engine::graph::Pipeline::parse` on arbitrary text (the bytes as lossy UTF-8), with the
//! built-in registry: `Ok` or `Err`, never a panic (`checks::pipeline`). Seed the corpus with
//! `../graphs/*.ron`: `mkdir -p corpus/pipeline && cp ../graphs/*.ron corpus/pipeline/`.
#![no_main]

#[path = "../checks.rs"]
mod checks;

use std::sync::OnceLock;

use hdrflow::Registry;
use libfuzzer_sys::fuzz_target;

fn registry() -> &'static Registry {
    static R: OnceLock<Registry> = OnceLock::new();
    R.get_or_init(hdrflow::builtin_registry)
}

fuzz_target!(|data: &[u8]| checks::pipeline(data, registry()));
