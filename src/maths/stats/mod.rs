//! Statistics of images: weighted means and percentiles, and error metrics of an image against a
//! reference (luminance by `crate::colour`'s Rec. 709 weights). Imports no other `maths` domain.

pub mod error_metrics;
pub mod protocol_metrics;
pub mod protocol_tonemap;
pub mod statistics;
