//! Camera views of a lat-long map through a [`crate::geometry::lens::Lens`] (perspective, fisheye,
//! orthographic): the views, their pastes back into a map, and each pixel's footprint mean.
//! Imports [`super::resample`].

pub mod area;
pub mod view;
