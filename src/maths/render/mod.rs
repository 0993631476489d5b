//! Sphere renderers and their exact references: the diffuse sphere relit from shared light
//! samples, per-pixel Monte Carlo (the path tracer's way) with its SIMD lanes, the glossy sphere,
//! the exact irradiance of a piecewise-constant map every estimator is measured against, and the
//! lighting-estimation protocol's probe spheres as Blender Cycles renders them.
//! Imports [`super::sampling`], [`super::brdf`] and [`super::stats`].

pub mod glossy;
pub mod kernels;
pub mod per_pixel;
pub mod probe_sphere;
pub mod reference;
pub mod relight;
pub mod shared_relight;
