//! Rendering data values to pictures (PNG and SVG plots).

pub mod curves_plot;
pub mod time_error;
