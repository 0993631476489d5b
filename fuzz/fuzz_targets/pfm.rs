//! `formats::pfm::decode` on arbitrary bytes: `Ok` or `Err`, never a panic; a decoded image is
//! well formed (`checks::pfm`).
#![no_main]

#[path = "../checks.rs"]
mod checks;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| checks::pfm(data));
