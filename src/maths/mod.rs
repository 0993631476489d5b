//! The mathematics behind the operators, free of the engine: conventions, sequences, lobes,
//! Fresnel, relighting kernels and statistical tests.

pub mod chi_square;
pub mod error_metrics;
pub mod fresnel;
pub mod latlong;
pub mod per_pixel;
pub mod phong;
pub mod reference;
pub mod relight;
pub mod sequences;
pub mod sh;
