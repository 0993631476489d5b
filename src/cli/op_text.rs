//! The words `hdrflow ops` and its Markdown pages share about an operator: what the cache keeps
//! of its results and the extensions `Save` writes a value type as.

use crate::engine::cache::Persist;
use crate::engine::registry::Registry;

/// What the cache keeps of an operator's results, in words.
pub(super) fn persist_text(persist: Persist) -> &'static str {
    match persist {
        Persist::Measured => "a large result is stored when slower to recompute than to read back",
        Persist::Always => "every result is stored",
        Persist::IfSmall => "a large result is stored only as a target (one cheap pass per byte)",
    }
}

/// `.exr .png`: the extensions `Save` writes a value type as ("" when it writes none).
pub(super) fn save_extensions(registry: &Registry, t: crate::engine::value::ValueType) -> String {
    let saves = registry.saver(t).map_or(&[][..], |s| s.extensions);
    saves.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(" ")
}
