//! Phase 7 (no two nodes write the same output path) and the output-path rule itself.

use std::collections::HashMap;
use std::path::{Component, Path};

use super::{Collector, RawNode};
use crate::engine::graph::Node;
use crate::engine::params::{FieldKind, ParamValue};

/// Phase 7: output paths are unique across the pipeline.
pub(super) fn check_outputs(nodes: &[Node], raw: &[RawNode], errs: &mut Collector) {
    let mut seen: HashMap<String, (usize, &'static str)> = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        for f in &n.spec.fields {
            if !matches!(f.kind, FieldKind::OutputPath) {
                continue;
            }
            let Some(ParamValue::Text(path)) = n.params.values.get(f.name) else { continue };
            let normal: Vec<String> = Path::new(path)
                .components()
                .filter(|c| !matches!(c, Component::CurDir))
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            let normal = normal.join("/");
            if let Some(&(first, _)) = seen.get(&normal) {
                let (pos, origin) = raw[i]
                    .fields
                    .iter()
                    .find(|(k, _, _)| k.value == f.name)
                    .map(|(_, v, o)| (v.pos, o.to_string()))
                    .unwrap_or((n.pos, errs.source.to_string()));
                errs.push_from(
                    &origin,
                    Some(pos),
                    Some(&n.name),
                    format!("output path {path:?} is also written by node {:?}", nodes[first].name),
                );
            } else {
                seen.insert(normal, (i, f.name));
            }
        }
    }
}

/// Checks that an output path is relative and stays inside the output folder.
pub fn check_output_path(rel: &str) -> Result<(), String> {
    let path = Path::new(rel);
    if rel.is_empty() {
        return Err("empty output path".into());
    }
    for c in path.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => return Err(format!("output path {rel:?} leaves the output folder (`..`)")),
            Component::RootDir | Component::Prefix(_) => {
                return Err(format!("output path {rel:?} is absolute: output paths are relative to --out"))
            }
        }
    }
    if path.file_name().is_none() {
        return Err(format!("output path {rel:?} names no file"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check_output_path;

    #[test]
    fn output_paths_stay_inside() {
        assert!(check_output_path("a.png").is_ok());
        assert!(check_output_path("sub/a.png").is_ok());
        let refused = |rel: &str, why: &str| check_output_path(rel).is_err_and(|e| e.contains(why));
        assert!(refused("../a.png", "leaves the output folder"));
        assert!(refused("sub/../../a.png", "leaves the output folder"));
        assert!(refused("/etc/passwd", "is absolute"));
        assert!(check_output_path("").is_err_and(|e| e == "empty output path"));
    }
}
