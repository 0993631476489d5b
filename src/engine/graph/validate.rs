//! Pipeline validation: syntax tree -> typed, acyclic `Pipeline`, or every problem with its position.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use petgraph::graph::DiGraph;

use super::syntax::{self, Pos, Ron, Spanned};
use super::{Node, Override, Pipeline};
use crate::engine::error::{PipelineError, PipelineErrors};
use crate::engine::op::{CheckContext, Default, FieldKind, FieldSpec, OpSpec, OutputType, ParamValue, Params};
use crate::engine::registry::Registry;
use crate::engine::value::ValueType;

/// A node as written, before its fields are checked.
struct RawNode {
    name: String,
    op_pos: Pos,
    spec: &'static OpSpec,
    /// Field name -> (position of the name, value, where it came from).
    fields: Vec<(Spanned<String>, Spanned<Ron>, String)>,
}

struct Collector<'a> {
    source: &'a str,
    errors: Vec<PipelineError>,
}

impl Collector<'_> {
    fn push(&mut self, pos: Option<Pos>, node: Option<&str>, message: impl Into<String>) {
        self.errors.push(PipelineError {
            source: self.source.to_string(),
            pos,
            node: node.map(str::to_string),
            message: message.into(),
        });
    }
    /// Like `push`, for a problem from `source` (the file or a `--set`); line 0 means no position.
    fn push_from(&mut self, source: &str, pos: Option<Pos>, node: Option<&str>, message: impl Into<String>) {
        let pos = pos.filter(|p| p.line > 0);
        self.errors.push(PipelineError {
            source: source.to_string(),
            pos,
            node: node.map(str::to_string),
            message: message.into(),
        });
    }
}

pub(super) fn validate(
    text: &str,
    source: &str,
    base_dir: &Path,
    registry: &Registry,
    overrides: &[Override],
) -> Result<Pipeline, PipelineErrors> {
    let mut errs = Collector { source, errors: Vec::new() };
    let root = syntax::parse(text).map_err(|e| {
        PipelineErrors(vec![PipelineError {
            source: source.to_string(),
            pos: Some(e.pos),
            node: None,
            message: e.message,
        }])
    })?;

    // The top level: `( nodes: { ... } )`, optionally named `Pipeline(...)`.
    let entries = match root.value {
        Ron::Struct { fields, .. } => {
            let mut nodes = None;
            for (name, value) in fields {
                if name.value == "nodes" {
                    nodes = Some(value);
                } else {
                    errs.push(
                        Some(name.pos),
                        None,
                        format!("unknown top-level field {:?} (expected: nodes)", name.value),
                    );
                }
            }
            match nodes {
                Some(Spanned { value: Ron::Map(entries), .. }) => entries,
                Some(other) => {
                    errs.push(
                        Some(other.pos),
                        None,
                        format!(
                            "`nodes` must be a map {{ \"name\": Operator(...) }}, found {}",
                            other.value.kind_name()
                        ),
                    );
                    return Err(PipelineErrors(errs.errors));
                }
                None => {
                    errs.push(Some(root.pos), None, "missing top-level field `nodes`");
                    return Err(PipelineErrors(errs.errors));
                }
            }
        }
        other => {
            errs.push(
                Some(root.pos),
                None,
                format!("a pipeline file is `( nodes: {{ ... }} )`, found {}", other.kind_name()),
            );
            return Err(PipelineErrors(errs.errors));
        }
    };

    // Nodes: names, operators, raw fields.
    let mut raw: Vec<RawNode> = Vec::new();
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
        let fields = fields.into_iter().map(|(k, v)| (k, v, source.to_string())).collect();
        raw.push(RawNode { name, op_pos: op_name.pos, spec, fields });
    }

    // `--set` overrides replace or add one field.
    for o in overrides {
        let origin = format!("--set {}.{}", o.node, o.field);
        let Some(node) = raw.iter_mut().find(|n| n.name == o.node) else {
            if seen.contains_key(&o.node) {
                continue; // the node itself is in error; already reported
            }
            let names: Vec<&str> = raw.iter().map(|n| n.name.as_str()).collect();
            errs.push_from(&origin, None, None, format!("no node named {:?} (nodes: {})", o.node, names.join(", ")));
            continue;
        };
        let kind = node.spec.field(&o.field).map(|f| f.kind);
        let is_text = matches!(kind, Some(FieldKind::Text | FieldKind::Path));
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
        let value = match (kind, value) {
            (Some(FieldKind::Path), Spanned { value: Ron::Str(path), pos })
                if !path.starts_with("builtin:") && std::path::Path::new(&path).is_relative() =>
            {
                let abs = std::env::current_dir().map(|d| d.join(&path)).unwrap_or_else(|_| path.clone().into());
                Spanned { value: Ron::Str(abs.to_string_lossy().into_owned()), pos }
            }
            (_, v) => v,
        };
        // A `--set` field name has no position in any file (line 0 = none).
        let field = Spanned { value: o.field.clone(), pos: Pos { line: 0, col: 0 } };
        node.fields.retain(|(k, _, _)| k.value != o.field);
        node.fields.push((field, value, origin));
    }

    // Fields: names, types, ranges, missing ones; inputs must name existing nodes.
    let index: HashMap<&str, usize> = raw.iter().enumerate().map(|(i, n)| (n.name.as_str(), i)).collect();
    let mut nodes: Vec<Node> = Vec::with_capacity(raw.len());
    let mut input_pos: Vec<BTreeMap<&'static str, (Pos, String)>> = Vec::with_capacity(raw.len());
    let mut structural_ok = true;
    for n in &raw {
        let mut params = Params::default();
        let mut inputs = BTreeMap::new();
        let mut positions = BTreeMap::new();
        let mut given: HashMap<&str, Pos> = HashMap::new();
        for (fname, fvalue, origin) in &n.fields {
            let Some(field) = n.spec.field(&fname.value) else {
                let names: Vec<&str> = n.spec.fields.iter().map(|f| f.name).collect();
                errs.push_from(
                    origin,
                    Some(fname.pos),
                    Some(&n.name),
                    format!("{} has no field {:?} (fields: {})", n.spec.name, fname.value, names.join(", ")),
                );
                structural_ok = false;
                continue;
            };
            if let Some(first) = given.insert(field.name, fname.pos) {
                if origin == source {
                    errs.push_from(
                        origin,
                        Some(fname.pos),
                        Some(&n.name),
                        format!("field {:?} given twice (first at {}:{})", field.name, first.line, first.col),
                    );
                    structural_ok = false;
                    continue;
                }
            }
            match &field.kind {
                FieldKind::Input(_) => match &fvalue.value {
                    Ron::Str(target) => match index.get(target.as_str()) {
                        Some(&i) => {
                            inputs.insert(field.name, i);
                            positions.insert(field.name, (fvalue.pos, origin.clone()));
                        }
                        // A node that exists but is itself in error was reported already.
                        None if seen.contains_key(target.as_str()) => structural_ok = false,
                        None => {
                            let names: Vec<&str> = raw.iter().map(|n| n.name.as_str()).collect();
                            errs.push_from(
                                origin,
                                Some(fvalue.pos),
                                Some(&n.name),
                                format!(
                                    "field {:?} names node {:?}, which does not exist (nodes: {})",
                                    field.name,
                                    target,
                                    names.join(", ")
                                ),
                            );
                            structural_ok = false;
                        }
                    },
                    other => {
                        errs.push_from(
                            origin,
                            Some(fvalue.pos),
                            Some(&n.name),
                            format!(
                                "field {:?} is an input: give the name of a node as a string, found {}",
                                field.name,
                                other.kind_name()
                            ),
                        );
                        structural_ok = false;
                    }
                },
                _ => match convert(field, &fvalue.value) {
                    Ok(v) => {
                        params.values.insert(field.name.to_string(), v);
                    }
                    Err(msg) => {
                        errs.push_from(
                            origin,
                            Some(fvalue.pos),
                            Some(&n.name),
                            format!("field {:?}: {msg}", field.name),
                        );
                        structural_ok = false;
                    }
                },
            }
        }
        for field in n.spec.fields {
            if given.contains_key(field.name) {
                continue;
            }
            match default_value(field) {
                Some(v) => {
                    params.values.insert(field.name.to_string(), v);
                }
                None => {
                    errs.push(
                        Some(n.op_pos),
                        Some(&n.name),
                        format!(
                            "{} is missing field {:?} ({}: {})",
                            n.spec.name,
                            field.name,
                            field.kind.describe(),
                            field.doc
                        ),
                    );
                    structural_ok = false;
                }
            }
        }
        nodes.push(Node {
            name: n.name.clone(),
            pos: n.op_pos,
            spec: n.spec,
            params,
            inputs,
            output_type: ValueType::File, // set by type inference below
        });
        input_pos.push(positions);
    }
    if !structural_ok || !errs.errors.is_empty() {
        return Err(PipelineErrors(errs.errors));
    }

    // The DAG, and its cycles.
    let mut graph: DiGraph<usize, &'static str> = DiGraph::new();
    let ids: Vec<_> = (0..nodes.len()).map(|i| graph.add_node(i)).collect();
    for (i, n) in nodes.iter().enumerate() {
        for (field, &j) in &n.inputs {
            graph.add_edge(ids[j], ids[i], field);
        }
    }
    let topo_order: Vec<usize> = match petgraph::algo::toposort(&graph, None) {
        Ok(order) => order.into_iter().map(|id| graph[id]).collect(),
        Err(_) => {
            for cycle in find_cycles(&nodes) {
                let names: Vec<&str> = cycle.iter().map(|&i| nodes[i].name.as_str()).collect();
                let first = cycle[0];
                errs.push(Some(nodes[first].pos), Some(&nodes[first].name), format!("cycle: {}", names.join(" -> ")));
            }
            return Err(PipelineErrors(errs.errors));
        }
    };

    // Types, in topological order: each input must receive a type its field accepts.
    for &i in &topo_order {
        let spec = nodes[i].spec;
        let mut input_types: BTreeMap<&'static str, ValueType> = BTreeMap::new();
        for field in spec.input_fields() {
            let FieldKind::Input(accepted) = field.kind else { continue };
            let Some(&j) = nodes[i].inputs.get(field.name) else { continue };
            let got = nodes[j].output_type;
            input_types.insert(field.name, got);
            if !accepted.contains(&got) {
                let (pos, origin) = input_pos[i][field.name].clone();
                let want: Vec<&str> = accepted.iter().map(|t| t.name()).collect();
                errs.push_from(
                    &origin,
                    Some(pos),
                    Some(&nodes[i].name),
                    format!(
                        "field {:?} expects {}, but node {:?} ({}) gives {}",
                        field.name,
                        want.join(" | "),
                        nodes[j].name,
                        nodes[j].spec.name,
                        got
                    ),
                );
            }
        }
        nodes[i].output_type = match spec.output {
            OutputType::Fixed(t) => t,
            OutputType::SameAsInput(f) => input_types.get(f).copied().unwrap_or(ValueType::Image),
        };
        if let Some(check) = spec.check {
            let ctx = CheckContext { params: &nodes[i].params, input_types: &input_types };
            if let Err(problem) = check(&ctx) {
                let (pos, origin) = problem
                    .field
                    .and_then(|f| {
                        raw[i].fields.iter().find(|(k, _, _)| k.value == f).map(|(_, v, o)| (v.pos, o.clone()))
                    })
                    .unwrap_or((nodes[i].pos, source.to_string()));
                errs.push_from(&origin, Some(pos), Some(&nodes[i].name), problem.message);
            }
        }
    }
    if !errs.errors.is_empty() {
        return Err(PipelineErrors(errs.errors));
    }

    Ok(Pipeline { source: source.to_string(), base_dir: base_dir.to_path_buf(), nodes, graph, topo_order })
}

fn unknown_operator_message(name: &str, registry: &Registry) -> String {
    let names = registry.names();
    let close: Vec<&str> = names
        .iter()
        .copied()
        .filter(|n| n.eq_ignore_ascii_case(name) || edit_distance(&n.to_lowercase(), &name.to_lowercase()) <= 2)
        .collect();
    if close.is_empty() {
        format!("unknown operator {name:?} (`hdrflow ops` lists them: {})", names.join(", "))
    } else {
        format!("unknown operator {name:?}; did you mean {}?", close.join(" or "))
    }
}

/// Levenshtein distance, for "did you mean" hints.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, &cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// Converts a literal to the field's parameter type, checking its range.
fn convert(field: &FieldSpec, value: &Ron) -> Result<ParamValue, String> {
    let found = || format!("expected {}, found {}", field.kind.describe(), describe_literal(value));
    match field.kind {
        FieldKind::Input(_) => unreachable!("inputs are edges"),
        FieldKind::Float { min, max } => {
            let v = match value {
                Ron::Float(v) => *v,
                Ron::Int(v) => *v as f64,
                _ => return Err(found()),
            };
            if v.is_nan() || v < min || v > max {
                return Err(format!("{v} is out of range (expected {})", field.kind.describe()));
            }
            Ok(ParamValue::Float(v))
        }
        FieldKind::Int { min, max } => match value {
            Ron::Int(v) if *v >= min && *v <= max => Ok(ParamValue::Int(*v)),
            Ron::Int(v) => Err(format!("{v} is out of range (expected {})", field.kind.describe())),
            _ => Err(found()),
        },
        FieldKind::Bool => match value {
            Ron::Bool(b) => Ok(ParamValue::Bool(*b)),
            _ => Err(found()),
        },
        FieldKind::Text | FieldKind::Path => match value {
            Ron::Str(s) => Ok(ParamValue::Text(s.clone())),
            _ => Err(found()),
        },
        FieldKind::Choice(options) => match value {
            Ron::Ident(s) | Ron::Str(s) if options.contains(&s.as_str()) => Ok(ParamValue::Choice(s.clone())),
            Ron::Ident(s) | Ron::Str(s) => Err(format!("{s:?} is not one of {}", options.join(", "))),
            _ => Err(found()),
        },
        FieldKind::Tuple { len, min, max } => match value {
            Ron::Tuple { name: None, items } if items.len() == len => {
                let mut out = Vec::with_capacity(len);
                for item in items {
                    let v = match item.value {
                        Ron::Float(v) => v,
                        Ron::Int(v) => v as f64,
                        _ => return Err(found()),
                    };
                    if v.is_nan() || v < min || v > max {
                        return Err(format!("component {v} is out of range [{min}, {max}]"));
                    }
                    out.push(v);
                }
                Ok(ParamValue::Tuple(out))
            }
            _ => Err(found()),
        },
    }
}

fn describe_literal(value: &Ron) -> String {
    match value {
        Ron::Str(s) => format!("string {s:?}"),
        Ron::Int(v) => format!("integer {v}"),
        Ron::Float(v) => format!("float {v}"),
        Ron::Bool(b) => format!("bool {b}"),
        Ron::Ident(s) => format!("identifier {s}"),
        Ron::Tuple { items, .. } => format!("a tuple of {}", items.len()),
        other => other.kind_name().to_string(),
    }
}

fn default_value(field: &FieldSpec) -> Option<ParamValue> {
    Some(match field.default {
        Default::Required => return None,
        Default::Float(v) => ParamValue::Float(v),
        Default::Int(v) => ParamValue::Int(v),
        Default::Bool(v) => ParamValue::Bool(v),
        Default::Text(v) => ParamValue::Text(v.to_string()),
        Default::Choice(v) => ParamValue::Choice(v.to_string()),
        Default::Tuple(v) => ParamValue::Tuple(v.to_vec()),
    })
}

/// Every elementary cycle reachable by DFS, each once, as node indices in edge order
/// (a -> b means b consumes a), closed by repeating its first node.
/// petgraph's toposort names only one node of a cycle; users need the whole loop.
fn find_cycles(nodes: &[Node]) -> Vec<Vec<usize>> {
    // consumers[i]: nodes that take i as an input.
    let mut consumers = vec![Vec::new(); nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        for &j in n.inputs.values() {
            consumers[j].push(i);
        }
    }
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Active,
        Done,
    }
    let mut mark = vec![Mark::New; nodes.len()];
    let mut cycles = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    fn dfs(
        v: usize,
        consumers: &[Vec<usize>],
        mark: &mut [Mark],
        stack: &mut Vec<usize>,
        cycles: &mut Vec<Vec<usize>>,
    ) {
        mark[v] = Mark::Active;
        stack.push(v);
        for &w in &consumers[v] {
            match mark[w] {
                Mark::New => dfs(w, consumers, mark, stack, cycles),
                Mark::Active => {
                    let start = stack.iter().position(|&s| s == w).expect("active node is on the stack");
                    let mut cycle: Vec<usize> = stack[start..].to_vec();
                    cycle.push(w);
                    cycles.push(cycle);
                }
                Mark::Done => {}
            }
        }
        stack.pop();
        mark[v] = Mark::Done;
    }
    for v in 0..nodes.len() {
        if mark[v] == Mark::New {
            dfs(v, &consumers, &mut mark, &mut stack, &mut cycles);
        }
    }
    cycles
}

#[cfg(test)]
mod tests {
    use super::edit_distance;

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("loadhdr", "loadhdr"), 0);
        assert_eq!(edit_distance("loadhrd", "loadhdr"), 2);
        assert_eq!(edit_distance("", "abc"), 3);
    }
}
