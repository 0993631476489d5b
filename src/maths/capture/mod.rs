//! The maths of capture, on plain slices of codes and floats (no operator, no file format):
//! camera response recovery, exposure merging and fusion, median-threshold-bitmap alignment.
//! It may import `values` (the `Brackets` type) and `maths::stats`; operators in
//! `crate::ops::capture` build on it.

pub mod codes;
