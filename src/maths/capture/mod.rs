//! The maths of capture, on plain slices of codes and floats (no operator, no file format):
//! camera response recovery, exposure merging and fusion, median-threshold-bitmap alignment,
//! illuminance calibration and two-view mirror-ball merging. It may import `values` (the
//! `Brackets` type), `geometry`, `maths::stats`, `maths::resample` and `maths::sampling` (the
//! seeded noise of synthetic brackets); operators in `crate::ops::capture` build on it.

pub mod align;
pub mod codes;
pub mod debevec;
pub mod fusion;
pub mod illuminance;
pub mod merge;
pub mod mtb;
pub mod response;
pub mod robertson;
pub mod simulate;
pub mod two_balls;

#[cfg(test)]
mod tests;
