//! Built-in operators, one file each, grouped by domain.
//!
//! To add an operator: write `src/ops/<domain>/<name>.rs` declaring `pub static SPEC: OpSpec`
//! and its `eval` (copy `image/exposure.rs`, the smallest), then add one line to that domain's
//! `register` function in its `mod.rs`.

pub mod image;
pub mod io;
pub mod plotting;
pub mod sampling;
pub mod shading;

use crate::engine::registry::Registry;

/// Registers every built-in operator.
pub fn register_all(registry: &mut Registry) {
    io::register(registry);
    image::register(registry);
    sampling::register(registry);
    shading::register(registry);
    plotting::register(registry);
}
