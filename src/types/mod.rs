//! The built-in value types: how each data type of `crate::data` is named, cached and saved.
//!
//! Each file declares one or two `TypeSpec`s and implements `ValueData` for its data type: the
//! cache payload (`encode`/`decode`, every length checked before allocating) and `Save`'s file
//! encoders. The engine knows none of them; `register_all` adds them to a registry. A value
//! type from outside the crate is declared the same way (see `examples/custom_operator.rs`).

pub mod camera;
pub mod cubemap;
pub mod curves;
pub mod distribution;
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

pub use self::image::{IMAGE, SCALAR_FIELD};
pub use camera::CAMERA;
pub use cubemap::{CUBEMAP, MIP_CHAIN};
pub use curves::CURVES;
pub use distribution::DISTRIBUTION;
pub use filament_sh::FILAMENT_SH;
pub use label::LABEL;
pub use light::LIGHT;
pub use lights::LIGHTS;
pub use metrics::METRICS;
pub use samples::SAMPLES;
pub use sg::SG;
pub use sh::SH_COEFFICIENTS;

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
    /// Either kind of image.
    pub const ANY_IMAGE: &[ValueType] = &[IMAGE_T, SCALAR_T];
}

/// CSV text of `records`, the header first, written by the `csv` crate: RFC 4180 quoting (a
/// field is quoted only when it holds a comma, a double quote or a line break, and its quotes
/// are doubled), `\n` after each record. Numbers are formatted by the caller, so that each file
/// keeps its own precision. A record of no field becomes `""` (one empty field), as the crate
/// writes it.
pub(crate) fn csv_text<R, F>(records: impl IntoIterator<Item = R>) -> String
where
    R: IntoIterator<Item = F>,
    F: AsRef<[u8]>,
{
    // Flexible: the records' lengths are the caller's (they agree in every file written here).
    let mut w = csv::WriterBuilder::new().flexible(true).from_writer(Vec::new());
    for record in records {
        // Writing into a Vec has no I/O to fail, and a flexible writer no length to refuse.
        w.write_record(record).expect("CSV into memory");
    }
    let bytes = w.into_inner().expect("CSV into memory");
    String::from_utf8(bytes).expect("UTF-8 fields give UTF-8 CSV")
}

/// A JSON number, or `null` for NaN and infinities (JSON has neither).
pub(crate) fn json_num(v: f64) -> serde_json::Value {
    serde_json::Number::from_f64(v).map(serde_json::Value::Number).unwrap_or(serde_json::Value::Null)
}
