//! Built-in operators, one file each, grouped by domain.
//!
//! To add an operator: write `src/ops/<domain>/<name>.rs` with its parameter struct
//! (`params!`) and a `spec()` function built with `engine::typed_op::Op` (copy
//! `image/flip_vertical.rs`, the smallest), then add one line to that domain's `register`
//! function in its `mod.rs`. The category is the folder and the code hash the file's. From outside the crate, register
//! it on `builtin_registry()` and run the command line over it with `hdrflow::cli::main_with`
//! (see `examples/custom_operator.rs`).

pub mod capture;
pub mod dataset;
pub mod evaluation;
pub mod ibl;
pub mod image;
pub mod io;
pub mod latlong_input;
pub mod layouts;
pub mod lights;
pub mod plotting;
pub mod sampling;
pub mod shading;

use crate::engine::registry::{Registry, RegistryError};

/// Registers every built-in operator, each with the code hash of its file.
pub fn register_all(registry: &mut Registry) -> Result<(), RegistryError> {
    registry.hash_sources_with(builtin_code_hash);
    io::register(registry)?;
    image::register(registry)?;
    layouts::register(registry)?;
    sampling::register(registry)?;
    shading::register(registry)?;
    lights::register(registry)?;
    plotting::register(registry)?;
    ibl::register(registry)?;
    dataset::register(registry)?;
    capture::register(registry)?;
    evaluation::register(registry)?;
    Ok(())
}

/// A registry with every built-in value type, how `Save` writes each, and every operator.
pub fn builtin_registry() -> Registry {
    let mut r = Registry::empty();
    crate::values::register_all(&mut r);
    crate::formats::save::register_all(&mut r);
    // The built-in names are distinct: `every_builtin_operator_registers_once` checks it.
    register_all(&mut r).expect("built-in operator names are unique");
    r
}

include!(concat!(env!("OUT_DIR"), "/op_sources.rs"));

/// The code hash of the built-in operator file at `file` (`file!()`, relative or absolute: the
/// entry of `build.rs`'s table of operator files it ends with), zero for a file the table does
/// not hold. [`register_all`] hands it to the registry, which stamps each operator with the
/// hash of the file its struct is declared in.
pub fn builtin_code_hash(file: &str) -> [u8; 32] {
    let file = file.replace('\\', "/");
    OP_SOURCES.iter().find(|(path, _)| file.ends_with(path)).map(|(_, h)| *h).unwrap_or([0; 32])
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_builtin_operator_registers_once() {
        let mut r = crate::engine::registry::Registry::empty();
        assert_eq!(super::register_all(&mut r), Ok(()));
        // Every built-in names its file, and that file has a hash.
        for spec in r.all() {
            assert_ne!(spec.code_hash, [0; 32], "{} has no code hash", spec.name);
        }
    }

    #[test]
    fn every_operator_file_has_a_code_hash() {
        assert!(super::OP_SOURCES.len() > 20);
        let h = super::builtin_code_hash("/abs/prefix/src/ops/image/exposure.rs");
        assert_ne!(h, [0; 32]);
        assert_eq!(h, super::builtin_code_hash("src/ops/image/exposure.rs"));
        assert_ne!(h, super::builtin_code_hash("src/ops/image/luminance.rs"));
    }
}
