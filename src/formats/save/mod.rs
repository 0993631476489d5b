//! `Save`'s encoders of the built-in value types: which extensions each type is written as, and
//! the bytes of each file, one file per family of types. Each registers its savers on a registry
//! (`Registry::register_saver`) with one line per type; [`register_all`] calls them, beside the
//! types' own registration (`crate::values::register_all`, both in `ops::builtin_registry`). So a
//! value type's module holds its data and cache codec only, saving a value as a file is the file
//! formats' job, and the engine still names no format.
//!
//! - [`image`]: images and scalar fields (`.png`, `.exr`, `.hdr`, `.pfm`, `.ktx2`, `.ktx`), and a
//!   distribution as the image of its pdf;
//! - [`cubemap`]: cube maps and mip chains (strips of the six faces, or KTX cube textures);
//! - [`curves`]: `.json`, `.csv`, and plots (`.png`, `.svg`, through `crate::plotting`);
//! - [`samples`], [`metrics`]: `.csv` and `.json` tables;
//! - [`sh`]: SH coefficients (`.json`, `.csv`) and Filament's SH (`.txt`, `.json`);
//! - [`as_json`]: the types saved as their JSON object (light, lights, sg, camera, label, exif);
//! - [`brackets`]: a bracket as one photograph per frame with its EXIF exposure time (`Save` writes
//!   the frames, as it writes a mip chain's levels).

pub mod as_json;
pub mod brackets;
pub mod cubemap;
pub mod curves;
pub mod image;
pub mod metrics;
pub mod samples;
pub mod sh;

use crate::engine::registry::Registry;

/// Registers how `Save` writes every built-in value type that can be saved.
pub fn register_all(r: &mut Registry) {
    image::register(r);
    cubemap::register(r);
    curves::register(r);
    samples::register(r);
    metrics::register(r);
    sh::register(r);
    as_json::register(r);
    brackets::register(r);
}
