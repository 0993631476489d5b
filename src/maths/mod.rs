//! The mathematics behind the operators, free of the engine: sequences, lobes, Fresnel,
//! relighting and its SIMD kernels, and statistical tests. The lat-long convention they all use
//! lives below them, in [`crate::geometry::latlong`].

pub mod chi_square;
pub mod error_metrics;
pub mod fresnel;
pub mod ggx;
pub mod glossy;
pub mod irradiance_cube;
pub mod kernels;
pub mod per_pixel;
pub mod phong;
pub mod reference;
pub mod relight;
pub mod resample;
pub mod sequences;
pub mod sh;
pub mod sun;
