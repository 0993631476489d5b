//! Resampling between spherical layouts and sizes, keeping energy: footprint means between
//! lat-long, cube and octahedral maps, area resizing, bilinear lookups, disc images (mirror ball,
//! angular), and rotated maps. Imports no other `maths` domain.

pub mod angles;
pub mod area_resize;
pub mod bilinear;
pub mod cell_clip;
pub mod cut_cells;
pub mod disc_image;
pub mod latlong_cube;
pub mod layouts;
pub(crate) mod polygon;
pub mod rotation;
