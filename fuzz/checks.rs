//! What each fuzz target asserts, one function per target, shared by the cargo-fuzz targets
//! (`fuzz_targets/*.rs`) and the corpus replays that CI runs (`tests/fuzz_regressions.rs`, which
//! includes this file with `#[path]`), so that a replay fails on exactly what the fuzzer reports
//! as a crash:
//! - a panic that escapes the entry point;
//! - a decoded image that is not well formed (a zero side, a channel count the reader never
//!   returns, a buffer of the wrong length);
//! - for EXR, a panic of the `exr` crate that `formats::exr::decode` caught and returned as
//!   [`FormatError::DecoderPanicked`]: the user gets an error instead of an abort, but it is a
//!   bug all the same (in hdrflow's use of the crate or in the crate itself).
// Each fuzz target uses one of these functions; the replays use all of them.
#![allow(dead_code)]

use std::path::Path;

use hdrflow::formats::FormatError;
use hdrflow::values::Image;
use hdrflow::{Pipeline, Registry};

/// A decoded image: both sides positive, `channels` one of `allowed`, `width * height *
/// channels` samples.
fn assert_well_formed(img: &Image, allowed: &[usize]) {
    assert!(
        img.width > 0 && img.height > 0 && allowed.contains(&img.channels),
        "malformed {}x{}x{} image",
        img.width,
        img.height,
        img.channels
    );
    assert_eq!(img.data.len(), img.width * img.height * img.channels);
}

/// `formats::rgbe::decode`: `Ok` with a well-formed RGB image or `Err`. (RGBE cannot encode NaN
/// or infinities, but see the known `EXPOSURE` overflow in tests/fuzz_readers.rs,
/// `regression_rgbe_small_exposure_gives_nan_and_inf`: values are not checked.)
pub fn rgbe(data: &[u8]) {
    if let Ok(img) = hdrflow::formats::rgbe::decode(data) {
        assert_well_formed(&img, &[3]);
    }
}

/// `formats::pfm::decode`: `Ok` with a well-formed image or `Err` (values are returned as
/// stored, NaN included, by design).
pub fn pfm(data: &[u8]) {
    if let Ok(img) = hdrflow::formats::pfm::decode(data) {
        assert_well_formed(&img, &[1, 3]);
    }
}

/// `formats::exr::decode`: `Ok` with a well-formed image or an `Err` that is not a caught panic.
pub fn exr(data: &[u8]) {
    match hdrflow::formats::exr::decode(data) {
        Ok(img) => assert_well_formed(&img, &[1, 3]),
        Err(e @ FormatError::DecoderPanicked(_)) => panic!("{e}"),
        Err(_) => {}
    }
}

/// `Pipeline::parse` on the bytes as lossy UTF-8, with `registry`: `Ok` or `Err`.
pub fn pipeline(data: &[u8], registry: &Registry) {
    let text = String::from_utf8_lossy(data);
    let _ = Pipeline::parse(&text, "fuzz.ron", Path::new("."), registry, &[]);
}
