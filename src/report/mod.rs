//! Presentations of a finished run, above the engine and beside the command line: the
//! self-contained HTML page of `hdrflow run --html` and `hdrflow watch --html`.

pub mod graph_svg;
pub mod html;
pub mod thumbnail;
