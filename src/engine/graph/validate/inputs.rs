//! Phase 8: every file a node reads exists and is a file. An input-path field (`FieldKind::Path`,
//! other than a `builtin:NAME`) that names no file is reported at its value, with the node, like
//! any other field error, rather than when the run reaches the node. A file that vanishes after
//! validation still fails the run, at the loader (its content key or its read).
//!
//! The nodes whose values the caller will provide (`Pipeline::parse_providing`) are not looked
//! at: their files are never read.

use std::path::Path;

use super::{Collector, RawNode};
use crate::engine::graph::Node;
use crate::engine::op::resolve_path;
use crate::engine::params::{FieldKind, ParamValue};

/// Phase 8: input files exist.
pub(super) fn check_input_files(
    nodes: &[Node],
    raw: &[RawNode],
    base_dir: &Path,
    provided: &[&str],
    errs: &mut Collector,
) {
    for (node, written) in nodes.iter().zip(raw) {
        if provided.contains(&node.name.as_str()) {
            continue;
        }
        for field in node.spec.fields.iter().filter(|f| matches!(f.kind, FieldKind::Path)) {
            let Some(ParamValue::Text(path)) = node.params.values.get(field.name) else { continue };
            let Some(problem) = missing_file(base_dir, path) else { continue };
            // The value's position in the file, or in its `--set` (which has none: line 0).
            let (pos, origin) = written
                .fields
                .iter()
                .find(|(k, _, _)| k.value == field.name)
                .map_or((node.pos, errs.source.to_string()), |(_, v, o)| (v.pos, o.to_string()));
            errs.push_from(&origin, Some(pos), Some(&node.name), format!("field {:?}: {problem}", field.name));
        }
    }
}

/// Why `path` (relative to `base_dir`) is not a file to read, or `None` when it is one or names a
/// built-in.
fn missing_file(base_dir: &Path, path: &str) -> Option<String> {
    if path.starts_with("builtin:") {
        return None;
    }
    let full = resolve_path(base_dir, path);
    if full.is_file() {
        return None;
    }
    let what = if full.is_dir() { "is a folder, not a file" } else { "does not exist" };
    if full == Path::new(path) {
        Some(format!("input file {path:?} {what}"))
    } else {
        Some(format!(
            "input file {path:?} {what} (looked for {}: a path is relative to the pipeline file's folder)",
            full.display()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::missing_file;
    use std::path::Path;

    #[test]
    fn a_missing_file_or_a_folder_is_named_with_where_it_was_looked_for() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.hdr"), b"").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        assert_eq!(missing_file(dir.path(), "a.hdr"), None);
        assert_eq!(missing_file(dir.path(), "builtin:sky"), None);
        let e = missing_file(dir.path(), "nope.hdr").unwrap();
        let full = dir.path().join("nope.hdr");
        assert_eq!(
            e,
            format!(
                "input file \"nope.hdr\" does not exist (looked for {}: a path is relative to the pipeline \
                 file's folder)",
                full.display()
            )
        );
        assert!(missing_file(dir.path(), "sub").unwrap().starts_with("input file \"sub\" is a folder, not a file"));
        assert_eq!(missing_file(Path::new(""), "nope.hdr").unwrap(), "input file \"nope.hdr\" does not exist");
    }
}
