//! Fitting models to maps: small least squares (Cholesky, NNLS), parametric lights and suns taken
//! out of a map with its integral kept, and spherical Gaussians fitted by Levenberg-Marquardt.
//! Imports [`super::resample`] and [`super::stats`].

pub mod least_squares;
pub mod lights;
pub mod spherical_gaussians;
pub mod sun;
pub mod sun_rule;
