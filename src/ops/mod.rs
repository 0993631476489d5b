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

/// A registry with every built-in value type, how `Save` writes each, and every operator.
pub fn builtin_registry() -> Registry {
    let mut r = Registry::empty();
    crate::values::register_all(&mut r);
    crate::formats::save::register_all(&mut r);
    register_all(&mut r);
    r
}

include!(concat!(env!("OUT_DIR"), "/op_sources.rs"));

/// The code hash of the built-in operator file at `file` (`file!()`, relative or absolute: the
/// entry of `build.rs`'s table of operator files it ends with), zero for a file the table does
/// not hold. An operator passes it to the engine with `OpSpec::code_hash`.
pub fn builtin_code_hash(file: &str) -> [u8; 32] {
    let file = file.replace('\\', "/");
    OP_SOURCES.iter().find(|(path, _)| file.ends_with(path)).map(|(_, h)| *h).unwrap_or([0; 32])
}

/// The code hash of the built-in operator file this macro is written in (see `OpSpec::code`).
#[doc(hidden)]
#[macro_export]
macro_rules! op_code_hash {
    () => {
        $crate::ops::builtin_code_hash(file!())
    };
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_operator_file_has_a_code_hash() {
        assert!(super::OP_SOURCES.len() > 20);
        let h = super::builtin_code_hash("/abs/prefix/src/ops/image/exposure.rs");
        assert_ne!(h, [0; 32]);
        assert_eq!(h, super::builtin_code_hash("src/ops/image/exposure.rs"));
        assert_ne!(h, super::builtin_code_hash("src/ops/image/luminance.rs"));
    }
}
