//! Phases 1 to 3: the top level, node names and operators, and `--set` overrides.

use std::collections::HashMap;
use std::path::Path;

use super::suggest::{suggest, suggest_field};
use super::{Collector, Origin, RawNode};
use crate::engine::graph::syntax::{self, Pos, Ron, Spanned};
use crate::engine::graph::Override;
use crate::engine::params::FieldKind;
use crate::engine::registry::Registry;

/// Phase 1: the top level `( nodes: { ... } )`, optionally named `Pipeline(...)`.
pub(super) fn top_level(root: Spanned<Ron>, errs: &mut Collector) -> Option<Vec<(Spanned<Ron>, Spanned<Ron>)>> {
    let Ron::Struct { fields, .. } = root.value else {
        errs.push(
            Some(root.pos),
            None,
            format!("a pipeline file is `( nodes: {{ ... }} )`, found {}", root.value.kind_name()),
        );
        return None;
    };
    let mut nodes = None;
    for (name, value) in fields {
        if name.value == "nodes" {
            nodes = Some(value);
        } else {
            errs.push(Some(name.pos), None, format!("unknown top-level field {:?} (expected: nodes)", name.value));
        }
    }
    match nodes {
        Some(Spanned { value: Ron::Map(entries), .. }) => Some(entries),
        Some(other) => {
            errs.push(
                Some(other.pos),
                None,
                format!("`nodes` must be a map {{ \"name\": Operator(...) }}, found {}", other.value.kind_name()),
            );
            None
        }
        None => {
            errs.push(Some(root.pos), None, "missing top-level field `nodes`");
            None
        }
    }
}

/// Phase 2: node names and operators. Returns the nodes that parsed, and every name written
/// (including nodes in error, so that references to them do not cascade into more errors).
pub(super) fn collect_nodes(
    entries: Vec<(Spanned<Ron>, Spanned<Ron>)>,
    registry: &Registry,
    errs: &mut Collector,
) -> (Vec<RawNode>, HashMap<String, Pos>) {
    let mut raw = Vec::new();
    let mut seen: HashMap<String, Pos> = HashMap::new();
    for (key, value) in entries {
        let name = match key.value {
            Ron::Str(s) => s,
            other => {
                errs.push(Some(key.pos), None, format!("node names are strings, found {}", other.kind_name()));
                continue;
            }
        };
        if name.is_empty() {
            errs.push(Some(key.pos), None, "empty node name");
            continue;
        }
        if let Some(first) = seen.get(&name) {
            errs.push(
                Some(key.pos),
                Some(&name),
                format!("duplicate node name (first defined at line {}:{})", first.line, first.col),
            );
            continue;
        }
        seen.insert(name.clone(), key.pos);
        let (op_name, fields) = match value.value {
            Ron::Struct { name: Some(op), fields } => (op, fields),
            Ron::Tuple { name: Some(op), items } if items.is_empty() => (op, Vec::new()),
            Ron::Ident(op) => (Spanned { value: op, pos: value.pos }, Vec::new()),
            Ron::Tuple { name: Some(op), .. } => {
                errs.push(
                    Some(op.pos),
                    Some(&name),
                    format!("{} takes named fields, e.g. {}(field: value)", op.value, op.value),
                );
                continue;
            }
            other => {
                errs.push(
                    Some(value.pos),
                    Some(&name),
                    format!("expected an operator such as `LoadHdr(path: \"...\")`, found {}", other.kind_name()),
                );
                continue;
            }
        };
        let Some(spec) = registry.get(&op_name.value) else {
            errs.push(Some(op_name.pos), Some(&name), unknown_operator_message(&op_name.value, registry));
            continue;
        };
        let origin: Origin = errs.source.into();
        let fields = fields.into_iter().map(|(k, v)| (k, v, origin.clone())).collect();
        raw.push(RawNode { name, op_pos: op_name.pos, spec: spec.clone(), fields });
    }
    (raw, seen)
}

/// Phase 3: `--set` overrides replace or add one field.
pub(super) fn apply_overrides(
    raw: &mut [RawNode],
    all_names: &HashMap<String, Pos>,
    overrides: &[Override],
    errs: &mut Collector,
) {
    for o in overrides {
        let origin = format!("--set {}.{}", o.node, o.field);
        let names: Vec<String> = raw.iter().map(|n| n.name.clone()).collect();
        let Some(node) = raw.iter_mut().find(|n| n.name == o.node) else {
            if all_names.contains_key(&o.node) {
                continue; // the node itself is in error; already reported
            }
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            errs.push_from(
                &origin,
                None,
                None,
                format!("no node named {:?}{}", o.node, suggest(&o.node, &names, "nodes")),
            );
            continue;
        };
        let Some(field) = node.spec.field(&o.field) else {
            let fields: Vec<&str> = node.spec.fields.iter().map(|f| f.name).collect();
            errs.push_from(
                &origin,
                None,
                Some(&o.node),
                format!("{} has no field {:?}{}", node.spec.name, o.field, suggest_field(&o.field, &fields)),
            );
            continue;
        };
        let kind = field.kind.clone();
        let is_text =
            matches!(kind, FieldKind::Text | FieldKind::Path | FieldKind::InputPattern | FieldKind::OutputPath);
        let value = match syntax::parse(&o.value) {
            Ok(v) if !is_text || matches!(v.value, Ron::Str(_)) => v,
            // A shell strips quotes: `--set env.path=../x.exr` means the string.
            _ if is_text => Spanned { value: Ron::Str(o.value.clone()), pos: Pos { line: 1, col: 1 } },
            Ok(v) => v,
            Err(e) => {
                errs.push_from(&origin, Some(e.pos), Some(&o.node), format!("bad value {:?}: {}", o.value, e.message));
                continue;
            }
        };
        // A relative path typed on the command line is relative to the working folder, not to
        // the pipeline file's (keys hold file contents, never paths, so this costs no cache hit).
        let value = match (&kind, value) {
            (FieldKind::Path | FieldKind::InputPattern, Spanned { value: Ron::Str(path), pos })
                if !path.starts_with("builtin:") && Path::new(&path).is_relative() =>
            {
                let abs = std::env::current_dir().map(|d| d.join(&path)).unwrap_or_else(|_| path.clone().into());
                Spanned { value: Ron::Str(abs.to_string_lossy().into_owned()), pos }
            }
            (_, v) => v,
        };
        // A `--set` field name has no position in any file (line 0 = none).
        let field_name = Spanned { value: o.field.clone(), pos: Pos { line: 0, col: 0 } };
        node.fields.retain(|(k, _, _)| k.value != o.field);
        node.fields.push((field_name, value, origin.as_str().into()));
    }
}

fn unknown_operator_message(name: &str, registry: &Registry) -> String {
    let names = registry.names();
    let hint = suggest(name, &names, "operators");
    if hint.is_empty() {
        format!("unknown operator {name:?} (`hdrflow ops` lists them: {})", names.join(", "))
    } else {
        format!("unknown operator {name:?}{hint}")
    }
}
