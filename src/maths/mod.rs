//! The mathematics behind the operators, free of the engine: conventions, sequences, lobes,
//! Fresnel, relighting kernels and statistical tests.

pub mod chi_square;
pub mod fresnel;
pub mod latlong;
pub mod phong;
pub mod relight;
pub mod sequences;
