//! Built-in operators, one file each, grouped by domain.
//!
//! To add an operator: write `src/ops/<domain>/<name>.rs` with its parameter struct
//! (`params!`) and a `spec()` function (copy `image/exposure.rs`, the smallest), then add one
//! line to that domain's `register` function in its `mod.rs`. From outside the crate, register
//! it on `builtin_registry()` and run the command line over it with `hdrflow::cli::main_with`
//! (see `examples/custom_operator.rs`).

pub mod dataset;
pub mod ibl;
pub mod image;
pub mod io;
pub mod latlong_input;
pub mod layouts;
pub mod lights;
pub mod plotting;
pub mod sampling;
pub mod shading;

use crate::engine::registry::Registry;

/// Registers every built-in operator.
pub fn register_all(registry: &mut Registry) {
    io::register(registry);
    image::register(registry);
    layouts::register(registry);
    sampling::register(registry);
    shading::register(registry);
    lights::register(registry);
    plotting::register(registry);
    ibl::register(registry);
    dataset::register(registry);
}

/// A registry with every built-in value type and operator.
pub fn builtin_registry() -> Registry {
    let mut r = Registry::empty();
    crate::types::register_all(&mut r);
    register_all(&mut r);
    r
}
