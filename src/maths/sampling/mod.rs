//! Sampling: point sequences in the unit square, warps that draw texels of a
//! [`crate::values::Distribution2D`] (guide tables, Mitsuba's hierarchical warp, texel centres),
//! multiple importance sampling weights, and the chi-square test that checks a sampler's
//! histogram against its pdf. Imports only [`crate::values`] and [`crate::geometry`].

pub mod chi_square;
pub mod guide_table;
pub mod hierarchical_warp;
pub mod mis;
pub mod sequences;
pub mod texel_samples;
