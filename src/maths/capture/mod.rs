//! The maths of capture, on plain slices of codes and floats (no operator, no file format):
//! camera response recovery, exposure merging and fusion, median-threshold-bitmap alignment,
//! illuminance calibration and two-view mirror-ball merging. It may import `values` (the
//! `Brackets` type), `geometry`, `maths::stats` and `maths::resample`; operators in
//! `crate::ops::capture` build on it.

pub mod align;
pub mod illuminance;
pub mod mtb;
pub mod two_balls;
