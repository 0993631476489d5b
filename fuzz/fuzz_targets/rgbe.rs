//! `formats::rgbe::decode` on arbitrary bytes: `Ok` or `Err`, never a panic; a decoded image is
//! well formed (`checks::rgbe`).
//!
//! Run with a memory limit so that allocation bombs are reported, e.g.
//! `cargo +nightly fuzz run rgbe -- -rss_limit_mb=1024`.
#![no_main]

#[path = "../checks.rs"]
mod checks;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| checks::rgbe(data));
