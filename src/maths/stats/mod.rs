//! Statistics of images: Rec. 709 luminance weights, weighted means and percentiles, and error
//! metrics of an image against a reference. Imports no other `maths` domain.

pub mod colour;
pub mod error_metrics;
pub mod statistics;
