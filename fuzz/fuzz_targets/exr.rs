//! `formats::exr::decode` on arbitrary bytes: `Ok` or `Err`, never a panic, caught or not
//! (`checks::exr`: `decode` turns a panic inside the `exr` crate into
//! `FormatError::DecoderPanicked`, which is reported here as a crash too).
#![no_main]

#[path = "../checks.rs"]
mod checks;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| checks::exr(data));
