//! The built-in values: the data that flows between operators, one module per type.
//!
//! A value is an immutable Rust value on a graph edge (`engine::value::Value`). Each module here
//! holds one data type and everything about it but its files: the type and its methods, the
//! `TypeSpec` that names it in pipelines, messages and cache entries, and its `ValueData` impl
//! (the cache payload, `encode` and `decode`, every length checked before allocating; what it
//! displays after a run, with `json` for the types shown as JSON). The codec sits beside the
//! type, so a type's fields are private unless they are its API. How `Save` writes a type as a
//! file belongs to the file formats (`crate::formats::save`), so this layer imports neither
//! `formats`, `plotting` nor `maths`. The engine knows none of these types; [`register_all`]
//! adds them to a registry.
//!
//! A type from outside the crate is declared the same way: a `static` [`TypeSpec`] (name, doc,
//! decode) plus `impl ValueData` for the Rust type, registered with
//! `Registry::register_type(&SPEC)` on the registry that `hdrflow::builtin_registry()` returns,
//! the one `examples/custom_operator.rs` hands to `hdrflow::cli::main_with`, and, to be saved,
//! its extensions and encoder with `Registry::register_saver(&SPEC, extensions, save)`
//! (`tests/engine2.rs` declares two such types; [`metrics`] is the smallest built-in one).
//!
//! [`TypeSpec`]: crate::engine::value::TypeSpec

pub mod brackets;
pub mod camera;
pub mod cubemap;
pub mod curves;
pub mod distribution;
pub mod exif;
pub mod filament_sh;
pub mod image;
pub(crate) mod json;
pub mod label;
pub mod light;
pub mod lights;
pub mod metrics;
pub mod samples;
pub mod sg;
pub mod sh;

use crate::engine::registry::Registry;
use crate::engine::value::ValueType;

pub use self::image::{Image, IMAGE, SCALAR_FIELD};
pub use brackets::{Brackets, BRACKETS};
pub use camera::{Camera, CAMERA};
pub use cubemap::{Cubemap, MipChain, CUBEMAP, MIP_CHAIN};
pub use curves::{Curves, CURVES};
pub use distribution::{Distribution2D, DISTRIBUTION};
pub use exif::{Exif, EXIF};
pub use filament_sh::{FilamentSh, FILAMENT_SH};
pub use label::{Label, LABEL};
pub use light::{Light, LIGHT};
pub use lights::{Lights, LIGHTS};
pub use metrics::{Metrics, METRICS};
pub use samples::{Sample, SampleSet, SAMPLES};
pub use sg::{SgLobe, SphericalGaussians, SG};
pub use sh::{ShCoefficients, ShFrame, SH_COEFFICIENTS};

/// Registers every built-in value type.
pub fn register_all(r: &mut Registry) {
    for spec in [
        &IMAGE,
        &SCALAR_FIELD,
        &DISTRIBUTION,
        &SAMPLES,
        &CURVES,
        &METRICS,
        &SH_COEFFICIENTS,
        &FILAMENT_SH,
        &LIGHT,
        &LIGHTS,
        &SG,
        &CUBEMAP,
        &MIP_CHAIN,
        &CAMERA,
        &LABEL,
        &BRACKETS,
        &EXIF,
    ] {
        r.register_type(spec);
    }
}

/// The built-in types as `ValueType`s, for operators' declarations.
pub mod ty {
    use super::*;
    /// An image of 2 or more channels (RGB, RGBA, ...; linear radiance).
    pub const IMAGE_T: ValueType = ValueType(&IMAGE);
    /// A one-channel image (luminance, weights, masks, a single channel).
    pub const SCALAR_T: ValueType = ValueType(&SCALAR_FIELD);
    pub const DISTRIBUTION_T: ValueType = ValueType(&DISTRIBUTION);
    pub const SAMPLES_T: ValueType = ValueType(&SAMPLES);
    pub const CURVES_T: ValueType = ValueType(&CURVES);
    pub const METRICS_T: ValueType = ValueType(&METRICS);
    pub const SH_COEFFICIENTS_T: ValueType = ValueType(&SH_COEFFICIENTS);
    pub const FILAMENT_SH_T: ValueType = ValueType(&FILAMENT_SH);
    pub const LIGHT_T: ValueType = ValueType(&LIGHT);
    pub const LIGHTS_T: ValueType = ValueType(&LIGHTS);
    pub const SG_T: ValueType = ValueType(&SG);
    pub const CUBEMAP_T: ValueType = ValueType(&CUBEMAP);
    pub const MIP_CHAIN_T: ValueType = ValueType(&MIP_CHAIN);
    pub const CAMERA_T: ValueType = ValueType(&CAMERA);
    pub const LABEL_T: ValueType = ValueType(&LABEL);
    pub const BRACKETS_T: ValueType = ValueType(&BRACKETS);
    pub const EXIF_T: ValueType = ValueType(&EXIF);
    /// Either kind of image.
    pub const ANY_IMAGE: &[ValueType] = &[IMAGE_T, SCALAR_T];
}
