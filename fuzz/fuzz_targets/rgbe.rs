//! `formats::rgbe::decode` on arbitrary bytes: `Ok` or `Err`, never a panic; a decoded image is
//! well formed. (RGBE cannot encode NaN or infinities, but see the known `EXPOSURE` overflow in
//! tests/fuzz_readers.rs, `regression_rgbe_small_exposure_gives_nan_and_inf`: values are not
//! checked here.)
//!
//! Run with a memory limit so that allocation bombs are reported, e.g.
//! `cargo +nightly fuzz run rgbe -- -rss_limit_mb=1024`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = hdrflow::formats::rgbe::decode(data) {
        assert!(img.width > 0 && img.height > 0 && img.channels == 3);
        assert_eq!(img.data.len(), img.width * img.height * img.channels);
    }
});
