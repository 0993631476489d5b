//! Pipeline validation: syntax tree -> typed, acyclic `Pipeline`, or every problem with its
//! position. The phases, each a function below:
//!
//! 1. `top_level`: the file is `( nodes: { "name": Operator(...), ... } )`.
//! 2. `collect_nodes`: names (unique, non-empty) and operators (known).
//! 3. `apply_overrides`: `--set NODE.FIELD=VALUE` replaces or adds one field.
//! 4. `resolve_fields`: each field is known, parameters convert to their kind and range, inputs
//!    name existing nodes and ports, with the declared arity; defaults fill the rest.
//! 5. `build_dag`: the petgraph DAG and a topological order, or every cycle.
//! 6. `infer_types`: in topological order, each input receives a type its field accepts, the
//!    operator's own check runs, and each output port gets its type.
//! 7. `check_outputs`: no two nodes write the same output path.
//!
//! No phase recurses over the graph, so a 100000-node chain validates in linear time.

use std::collections::{BTreeMap, HashMap};
use std::path::{Component, Path};
use std::sync::Arc;

use petgraph::graph::DiGraph;

use super::syntax::{self, Pos, Ron, Spanned};
use super::{InputWire, Node, Override, Pipeline, Port, PortRef};
use crate::engine::error::{PipelineError, PipelineErrors};
use crate::engine::op::{check_pixels, CheckContext, OpSpec, OutputType};
use crate::engine::params::{Arity, FieldKind, FieldSpec, ParamValue, Params};
use crate::engine::registry::Registry;
use crate::engine::value::ValueType;

/// A node as written, before its fields are checked.
struct RawNode {
    name: String,
    op_pos: Pos,
    spec: Arc<OpSpec>,
    /// (field name with its position, value, where it came from: the file or a `--set`).
    fields: Vec<(Spanned<String>, Spanned<Ron>, Origin)>,
}

/// Where a field came from: the pipeline file's name or `--set NODE.FIELD` (shared, not copied
/// per field).
type Origin = std::rc::Rc<str>;

/// A port name: declared ones borrowed from the operator's spec, open ones owned.
type PortName = std::borrow::Cow<'static, str>;

/// A reference to a node's port as written, before ports are resolved to indices.
struct WrittenRef {
    node: usize,
    port: PortName,
    pos: Pos,
    origin: Origin,
}

/// Every problem found so far.
struct Collector<'a> {
    source: &'a str,
    errors: Vec<PipelineError>,
}

impl Collector<'_> {
    fn push(&mut self, pos: Option<Pos>, node: Option<&str>, message: impl Into<String>) {
        let source = self.source.to_string();
        self.push_from(&source, pos, node, message);
    }
    /// Like `push`, for a problem from `origin` (the file or a `--set`); line 0 means no position.
    fn push_from(&mut self, origin: &str, pos: Option<Pos>, node: Option<&str>, message: impl Into<String>) {
        self.errors.push(PipelineError {
            source: origin.to_string(),
            pos: pos.filter(|p| p.line > 0),
            node: node.map(str::to_string),
            message: message.into(),
        });
    }
    fn fail(self) -> PipelineErrors {
        PipelineErrors(self.errors)
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
    let Some(entries) = top_level(root, &mut errs) else { return Err(errs.fail()) };
    let (mut raw, all_names) = collect_nodes(entries, registry, &mut errs);
    apply_overrides(&mut raw, &all_names, overrides, &mut errs);
    let Some((mut nodes, refs, port_names)) = resolve_fields(&raw, &all_names, source, &mut errs) else {
        return Err(errs.fail());
    };
    let Some((graph, topo_order)) = build_dag(&nodes, &mut errs) else { return Err(errs.fail()) };
    infer_types(&mut nodes, &raw, &refs, port_names, &topo_order, base_dir, &mut errs);
    if errs.errors.is_empty() {
        check_outputs(&nodes, &raw, &mut errs);
    }
    if !errs.errors.is_empty() {
        return Err(errs.fail());
    }
    Ok(Pipeline {
        source: source.to_string(),
        base_dir: base_dir.to_path_buf(),
        nodes,
        graph,
        topo_order,
        registry: registry.clone(),
        provided: Default::default(),
    })
}

/// Phase 1: the top level `( nodes: { ... } )`, optionally named `Pipeline(...)`.
fn top_level(root: Spanned<Ron>, errs: &mut Collector) -> Option<Vec<(Spanned<Ron>, Spanned<Ron>)>> {
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
fn collect_nodes(
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
fn apply_overrides(
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
                format!("{} has no field {:?}{}", node.spec.name, o.field, suggest(&o.field, &fields, "fields")),
            );
            continue;
        };
        let kind = field.kind.clone();
        let is_text = matches!(kind, FieldKind::Text | FieldKind::Path | FieldKind::OutputPath);
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
            (FieldKind::Path, Spanned { value: Ron::Str(path), pos })
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

/// What phase 4 produces: nodes with parameters and wiring (port indices into `port_names`),
/// the written position of every reference, and each node's port names.
type Resolved = (Vec<Node>, Vec<BTreeMap<&'static str, Vec<WrittenRef>>>, Vec<Vec<PortName>>);

/// Phase 4: fields, parameters, references and defaults.
fn resolve_fields(
    raw: &[RawNode],
    all_names: &HashMap<String, Pos>,
    source: &str,
    errs: &mut Collector,
) -> Option<Resolved> {
    let index: HashMap<&str, usize> = raw.iter().enumerate().map(|(i, n)| (n.name.as_str(), i)).collect();
    let node_names: Vec<&str> = raw.iter().map(|n| n.name.as_str()).collect();
    // Port names per node: the declared ones first; open ports are appended as consumers name them.
    let mut port_names: Vec<Vec<PortName>> =
        raw.iter().map(|n| n.spec.outputs.iter().map(|p| PortName::Borrowed(p.name)).collect()).collect();
    let mut nodes = Vec::with_capacity(raw.len());
    let mut all_refs = Vec::with_capacity(raw.len());
    let mut ok = true;
    for n in raw {
        let mut params = Params::default();
        let mut wired: BTreeMap<&'static str, Vec<WrittenRef>> = BTreeMap::new();
        // Fields given so far (a handful per node: a vector beats a hash map).
        let mut given: Vec<(&'static str, Pos)> = Vec::with_capacity(n.fields.len());
        for (fname, fvalue, origin) in &n.fields {
            let Some(field) = n.spec.field(&fname.value) else {
                let fields: Vec<&str> = n.spec.fields.iter().map(|f| f.name).collect();
                errs.push_from(
                    origin,
                    Some(fname.pos),
                    Some(&n.name),
                    format!(
                        "{} has no field {:?}{}",
                        n.spec.name,
                        fname.value,
                        suggest(&fname.value, &fields, "fields")
                    ),
                );
                ok = false;
                continue;
            };
            let earlier = given.iter().find(|(g, _)| *g == field.name).map(|&(_, p)| p);
            given.push((field.name, fname.pos));
            if let Some(first) = earlier {
                if &**origin == source {
                    errs.push_from(
                        origin,
                        Some(fname.pos),
                        Some(&n.name),
                        format!("field {:?} given twice (first at {}:{})", field.name, first.line, first.col),
                    );
                    ok = false;
                    continue;
                }
            }
            if let FieldKind::Input { arity, .. } = &field.kind {
                let items: Vec<&Spanned<Ron>> = match (&fvalue.value, arity) {
                    (Ron::List(items), Arity::List { .. }) => items.iter().collect(),
                    (Ron::Str(_), _) => vec![fvalue],
                    (other, arity) => {
                        let want = match arity {
                            Arity::List { .. } => "a list of node names, e.g. [\"a\", \"b.port\"]",
                            _ => "the name of a node as a string",
                        };
                        errs.push_from(
                            origin,
                            Some(fvalue.pos),
                            Some(&n.name),
                            format!("field {:?} is an input: give {want}, found {}", field.name, other.kind_name()),
                        );
                        ok = false;
                        continue;
                    }
                };
                if let Arity::List { min, max } = *arity {
                    if items.len() < min || items.len() > max {
                        let range =
                            if max == usize::MAX { format!("at least {min}") } else { format!("{min} to {max}") };
                        errs.push_from(
                            origin,
                            Some(fvalue.pos),
                            Some(&n.name),
                            format!("field {:?} takes {range} nodes, found {}", field.name, items.len()),
                        );
                        ok = false;
                        continue;
                    }
                }
                let mut refs = Vec::with_capacity(items.len());
                for item in items {
                    let Ron::Str(target) = &item.value else {
                        errs.push_from(
                            origin,
                            Some(item.pos),
                            Some(&n.name),
                            format!(
                                "field {:?} is an input: each item names a node as a string, found {}",
                                field.name,
                                item.value.kind_name()
                            ),
                        );
                        ok = false;
                        continue;
                    };
                    match resolve_ref(target, &index, raw, &mut port_names) {
                        Ok((node, port)) => refs.push(WrittenRef { node, port, pos: item.pos, origin: origin.clone() }),
                        // A node that exists but is itself in error was reported already.
                        Err(RefError::NoNode) if names_a_node_in_error(target, all_names) => ok = false,
                        Err(RefError::NoNode) => {
                            errs.push_from(
                                origin,
                                Some(item.pos),
                                Some(&n.name),
                                format!(
                                    "field {:?} names node {:?}, which does not exist{}",
                                    field.name,
                                    target,
                                    suggest(target, &node_names, "nodes")
                                ),
                            );
                            ok = false;
                        }
                        Err(RefError::NoPort { node, port }) => {
                            let spec = &raw[node].spec;
                            let ports: Vec<&str> = spec.outputs.iter().map(|p| p.name).collect();
                            let message = if ports.is_empty() && port.is_empty() {
                                // `"split"` for an operator with only open ports.
                                format!(
                                    "field {:?}: node {:?} has no default output: name one of its ports, \
                                     e.g. \"{}.NAME\" ({} has ports under any name: {})",
                                    field.name,
                                    raw[node].name,
                                    raw[node].name,
                                    spec.name,
                                    spec.open_ports.as_ref().map_or("", |o| o.doc)
                                )
                            } else {
                                let listing = if ports.is_empty() {
                                    format!("{} has no default output: name one of its ports", spec.name)
                                } else {
                                    format!("{} has ports: {}", spec.name, ports.join(", "))
                                };
                                format!(
                                    "field {:?}: node {:?} has no output port {:?}{} ({listing})",
                                    field.name,
                                    raw[node].name,
                                    port,
                                    did_you_mean(&port, &ports)
                                )
                            };
                            errs.push_from(origin, Some(item.pos), Some(&n.name), message);
                            ok = false;
                        }
                    }
                }
                wired.insert(field.name, refs);
                continue;
            }
            match convert(field, &fvalue.value) {
                Ok(v) => {
                    params.values.insert(field.name, v);
                }
                Err(msg) => {
                    errs.push_from(origin, Some(fvalue.pos), Some(&n.name), format!("field {:?}: {msg}", field.name));
                    ok = false;
                }
            }
        }
        for field in &n.spec.fields {
            if given.iter().any(|(g, _)| *g == field.name) {
                continue;
            }
            match (&field.kind, &field.default) {
                (FieldKind::Input { arity: Arity::Optional | Arity::List { min: 0, .. }, .. }, _) => {
                    wired.insert(field.name, Vec::new());
                }
                (FieldKind::Input { .. }, _) | (_, None) if !field.optional => {
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
                    ok = false;
                }
                (_, Some(v)) => {
                    params.values.insert(field.name, v.clone());
                }
                // An optional parameter left out stays absent: its field is `None`.
                (_, None) => {}
            }
        }
        let inputs = n
            .spec
            .input_fields()
            .map(|f| InputWire {
                field: f.name,
                sources: wired
                    .get(f.name)
                    .map(|refs| {
                        refs.iter()
                            .map(|r| PortRef { node: r.node, port: port_index(&port_names[r.node], &r.port) })
                            .collect()
                    })
                    .unwrap_or_default(),
            })
            .collect();
        nodes.push(Node {
            name: n.name.clone(),
            pos: n.op_pos,
            spec: n.spec.clone(),
            params,
            inputs,
            ports: Vec::new(), // typed by `infer_types`
            size: None,        // known, if at all, after `infer_types`
        });
        all_refs.push(wired);
    }
    if !ok || !errs.errors.is_empty() {
        return None;
    }
    Some((nodes, all_refs, port_names))
}

fn port_index(ports: &[PortName], name: &str) -> usize {
    ports.iter().position(|p| p == name).expect("port names are resolved before their index is taken")
}

enum RefError {
    NoNode,
    NoPort { node: usize, port: String },
}

/// Whether `target` is `node` or `node.port` for a node that was written but is in error.
fn names_a_node_in_error(target: &str, all_names: &HashMap<String, Pos>) -> bool {
    all_names.contains_key(target) || target.rmatch_indices('.').any(|(at, _)| all_names.contains_key(&target[..at]))
}

/// Resolves `"node"` (its default port) or `"node.port"`; a whole name with dots wins over a
/// split, and the longest node name before a dot over shorter ones. An open port named for the first time is added to the node's ports.
fn resolve_ref(
    target: &str,
    index: &HashMap<&str, usize>,
    raw: &[RawNode],
    port_names: &mut [Vec<PortName>],
) -> Result<(usize, PortName), RefError> {
    if let Some(&i) = index.get(target) {
        return match raw[i].spec.outputs.first() {
            Some(p) => Ok((i, PortName::Borrowed(p.name))),
            None => Err(RefError::NoPort { node: i, port: String::new() }),
        };
    }
    // The longest node name before a dot wins, so a port may itself contain dots (an EXR layer's
    // channel `diffuse.R`: `split.diffuse.R`).
    let mut found = None;
    for (at, _) in target.rmatch_indices('.') {
        if let Some(&i) = index.get(&target[..at]) {
            found = Some((i, &target[at + 1..]));
            break;
        }
    }
    let Some((i, port)) = found else { return Err(RefError::NoNode) };
    let spec = &raw[i].spec;
    if let Some(p) = spec.port(port) {
        return Ok((i, PortName::Borrowed(p.name)));
    }
    if spec.open_ports.is_some() && !port.is_empty() {
        if !port_names[i].iter().any(|p| p == port) {
            port_names[i].push(PortName::Owned(port.to_string()));
        }
        return Ok((i, PortName::Owned(port.to_string())));
    }
    Err(RefError::NoPort { node: i, port: port.to_string() })
}

/// Phase 5: the DAG and a topological order; on cycles, every elementary cycle found.
fn build_dag(nodes: &[Node], errs: &mut Collector) -> Option<(DiGraph<usize, &'static str>, Vec<usize>)> {
    let mut graph: DiGraph<usize, &'static str> = DiGraph::with_capacity(nodes.len(), nodes.len());
    let ids: Vec<_> = (0..nodes.len()).map(|i| graph.add_node(i)).collect();
    for (i, n) in nodes.iter().enumerate() {
        for w in &n.inputs {
            for s in &w.sources {
                graph.add_edge(ids[s.node], ids[i], w.field);
            }
        }
    }
    match petgraph::algo::toposort(&graph, None) {
        Ok(order) => {
            let order = order.into_iter().map(|id| graph[id]).collect();
            Some((graph, order))
        }
        Err(_) => {
            for cycle in find_cycles(nodes) {
                let names: Vec<&str> = cycle.iter().map(|&i| nodes[i].name.as_str()).collect();
                let first = cycle[0];
                errs.push(Some(nodes[first].pos), Some(&nodes[first].name), format!("cycle: {}", names.join(" -> ")));
            }
            None
        }
    }
}

/// Phase 6: types in topological order.
fn infer_types(
    nodes: &mut [Node],
    raw: &[RawNode],
    refs: &[BTreeMap<&'static str, Vec<WrittenRef>>],
    port_names: Vec<Vec<PortName>>,
    topo_order: &[usize],
    base_dir: &Path,
    errs: &mut Collector,
) {
    let source = errs.source;
    for &i in topo_order {
        let spec = nodes[i].spec.clone();
        let mut input_types: BTreeMap<&'static str, Vec<ValueType>> = BTreeMap::new();
        let mut types_ok = true;
        for w in &nodes[i].inputs {
            let FieldKind::Input { types: accepted, .. } = &spec.field(w.field).expect("declared input").kind else {
                continue;
            };
            let mut got_types = Vec::with_capacity(w.sources.len());
            for (k, s) in w.sources.iter().enumerate() {
                let Some(port) = nodes[s.node].ports.get(s.port) else {
                    // The producer failed its own checks; it was reported.
                    types_ok = false;
                    continue;
                };
                let got = port.ty;
                got_types.push(got);
                if !accepted.is_empty() && !accepted.contains(&got) {
                    let r = &refs[i][w.field][k];
                    let want: Vec<&str> = accepted.iter().map(|t| t.name()).collect();
                    let producer = &nodes[r.node];
                    let label = if producer.is_default_port(s.port) {
                        format!("node {:?}", producer.name)
                    } else {
                        format!("port {:?}", format!("{}.{}", producer.name, r.port))
                    };
                    errs.push_from(
                        &r.origin,
                        Some(r.pos),
                        Some(&nodes[i].name),
                        format!(
                            "field {:?} expects {}, but {} ({}) gives {}",
                            w.field,
                            want.join(" | "),
                            label,
                            producer.spec.name,
                            got
                        ),
                    );
                    types_ok = false;
                }
            }
            input_types.insert(w.field, got_types);
        }
        if !types_ok {
            continue;
        }
        let input_sizes: BTreeMap<&'static str, Vec<Option<(u64, u64)>>> = nodes[i]
            .inputs
            .iter()
            .map(|w| (w.field, w.sources.iter().map(|s| nodes[s.node].port_size(s.port)).collect()))
            .collect();
        let ctx =
            CheckContext { params: &nodes[i].params, input_types: &input_types, input_sizes: &input_sizes, base_dir };
        let field_pos = |field: Option<&'static str>| -> (Pos, String) {
            field
                .and_then(|f| {
                    raw[i].fields.iter().find(|(k, _, _)| k.value == f).map(|(_, v, o)| (v.pos, o.to_string()))
                })
                .unwrap_or((nodes[i].pos, source.to_string()))
        };
        // A node that fails its own check still gets its ports typed, so that the nodes after it
        // are validated too (all problems at once).
        if let Some(check) = &spec.check {
            if let Err(problem) = check(&ctx) {
                let (pos, origin) = field_pos(problem.field);
                errs.push_from(&origin, Some(pos), Some(&nodes[i].name), problem.message);
            }
        }
        let mut ports = Vec::with_capacity(port_names[i].len());
        let mut ports_ok = true;
        for name in &port_names[i] {
            let ty = match spec.port(name) {
                Some(p) => match &p.ty {
                    OutputType::Fixed(t) => Ok(*t),
                    OutputType::Computed(_, f) => f(&ctx),
                },
                None => Ok(spec.open_ports.as_ref().expect("open ports were resolved against the spec").ty),
            };
            match ty {
                Ok(ty) => ports.push(Port { name: name.clone(), ty }),
                Err(message) => {
                    errs.push(Some(nodes[i].pos), Some(&nodes[i].name), message);
                    ports_ok = false;
                }
            }
        }
        if ports_ok {
            // The pixel budget, for every node whose output size is known before running.
            let mut size = spec.size.as_ref().and_then(|f| f(&ctx));
            if let Some(Err(message)) = size.map(|(w, h)| check_pixels(w, h)) {
                let (pos, origin) = field_pos(spec.field("width").map(|f| f.name));
                errs.push_from(&origin, Some(pos), Some(&nodes[i].name), message);
                size = None;
            }
            nodes[i].ports = ports;
            nodes[i].size = size;
        }
    }
}

/// Phase 7: output paths are unique across the pipeline.
fn check_outputs(nodes: &[Node], raw: &[RawNode], errs: &mut Collector) {
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

fn unknown_operator_message(name: &str, registry: &Registry) -> String {
    let names = registry.names();
    let hint = suggest(name, &names, "operators");
    if hint.is_empty() {
        format!("unknown operator {name:?} (`hdrflow ops` lists them: {})", names.join(", "))
    } else {
        format!("unknown operator {name:?}{hint}")
    }
}

/// "; did you mean X?" for close candidates (case-insensitive, edit distance at most 2, or
/// a third of the name), else " (WHAT: ...)" listing them all, or "" when there are none.
pub fn suggest(name: &str, candidates: &[&str], what: &str) -> String {
    match suggest_close(name, candidates) {
        close if !close.is_empty() => close,
        _ if candidates.is_empty() => String::new(),
        _ if candidates.len() <= 24 => format!(" ({what}: {})", candidates.join(", ")),
        _ => format!(" ({what}: {}, ... {} in all)", candidates[..24].join(", "), candidates.len()),
    }
}

/// `"; did you mean ..."` when a candidate is close to `name` (a few edits, or a prefix),
/// else nothing: for messages that list the candidates themselves.
pub fn suggest_close(name: &str, candidates: &[&str]) -> String {
    let lower = name.to_lowercase();
    let limit = 2.max(name.chars().count() / 3);
    let mut close: Vec<(usize, &str)> = candidates
        .iter()
        .map(|c| {
            let cl = c.to_lowercase();
            // A prefix typed short ("lumi" for "luminance") is as close as one edit.
            let d = if !lower.is_empty() && cl.starts_with(&lower) { 1 } else { edit_distance(&cl, &lower) };
            (d, *c)
        })
        .filter(|(d, _)| *d <= limit)
        .collect();
    close.sort();
    if let Some(&(_, best)) = close.first() {
        let more: Vec<&str> = close.iter().skip(1).take(2).map(|(_, c)| *c).collect();
        if more.is_empty() {
            format!("; did you mean {best:?}?")
        } else {
            format!(
                "; did you mean {best:?} (or {})?",
                more.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(", ")
            )
        }
    } else {
        String::new()
    }
}

/// Only the "; did you mean X?" part of [`suggest`] (or "" when nothing is close).
fn did_you_mean(name: &str, candidates: &[&str]) -> String {
    let hint = suggest(name, candidates, "");
    if hint.starts_with(';') {
        hint
    } else {
        String::new()
    }
}

/// Levenshtein distance in characters, for "did you mean" hints.
fn edit_distance(a: &str, b: &str) -> usize {
    strsim::levenshtein(a, b)
}

/// Converts a literal to the field's parameter type, checking its range.
fn convert(field: &FieldSpec, value: &Ron) -> Result<ParamValue, String> {
    let found = || format!("expected {}, found {}", field.kind.describe(), describe_literal(value));
    let number = |v: &Ron| match v {
        Ron::Float(v) => Some(*v),
        Ron::Int(v) => Some(*v as f64),
        _ => None,
    };
    match &field.kind {
        FieldKind::Input { .. } => unreachable!("inputs are edges"),
        FieldKind::Float { min, max } => {
            let v = number(value).ok_or_else(found)?;
            if v.is_nan() || v < *min || v > *max {
                return Err(format!("{v} is out of range (expected {})", field.kind.describe()));
            }
            Ok(ParamValue::Float(v))
        }
        FieldKind::Int { min, max } => match value {
            Ron::Int(v) if v >= min && v <= max => Ok(ParamValue::Int(*v)),
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
        FieldKind::OutputPath => match value {
            Ron::Str(s) => {
                check_output_path(s)?;
                Ok(ParamValue::Text(s.clone()))
            }
            _ => Err(found()),
        },
        FieldKind::TextList { min, max } => match value {
            Ron::List(items) => {
                if items.len() < *min || items.len() > *max {
                    return Err(format!("expected {min} to {max} strings, found {}", items.len()));
                }
                items
                    .iter()
                    .map(|i| match &i.value {
                        Ron::Str(s) => Ok(s.clone()),
                        _ => Err(found()),
                    })
                    .collect::<Result<_, _>>()
                    .map(ParamValue::TextList)
            }
            _ => Err(found()),
        },
        FieldKind::Choice(options) => match value {
            Ron::Ident(s) | Ron::Str(s) if options.contains(&s.as_str()) => Ok(ParamValue::Choice(s.clone())),
            Ron::Ident(s) | Ron::Str(s) => {
                Err(format!("{s:?} is not one of {}{}", options.join(", "), suggest_close(s, options)))
            }
            _ => Err(found()),
        },
        FieldKind::Tuple { len, min, max } => match value {
            Ron::Tuple { name: None, items } if items.len() == *len => tuple(items, *min, *max, found),
            _ => Err(found()),
        },
        FieldKind::Color { min, max } => match value {
            Ron::Tuple { name: None, items } if items.len() == 3 => tuple(items, *min, *max, found),
            Ron::Int(_) | Ron::Float(_) => {
                let v = number(value).expect("a number");
                if v.is_nan() || v < *min || v > *max {
                    return Err(format!("{v} is out of range [{min}, {max}]"));
                }
                Ok(ParamValue::Tuple(vec![v; 3]))
            }
            _ => Err(found()),
        },
        FieldKind::NumberList { min_len, max_len, min, max } => match value {
            Ron::List(items) | Ron::Tuple { name: None, items } => {
                if items.len() < *min_len || items.len() > *max_len {
                    return Err(format!("expected {min_len} to {max_len} numbers, found {}", items.len()));
                }
                tuple(items, *min, *max, found)
            }
            _ => Err(found()),
        },
    }
}

fn tuple(items: &[Spanned<Ron>], min: f64, max: f64, found: impl Fn() -> String) -> Result<ParamValue, String> {
    let mut out = Vec::with_capacity(items.len());
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

/// Every elementary cycle reachable by DFS, each once, as node indices in edge order
/// (a -> b means b consumes a), closed by repeating its first node. petgraph's toposort names
/// only one node of a cycle; users need the whole loop. Iterative (an explicit stack), so a
/// long chain cannot overflow the thread's stack.
fn find_cycles(nodes: &[Node]) -> Vec<Vec<usize>> {
    let mut consumers = vec![Vec::new(); nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        for s in n.sources() {
            consumers[s.node].push(i);
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
    for root in 0..nodes.len() {
        if mark[root] != Mark::New {
            continue;
        }
        // (node, index of the next consumer to visit)
        let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
        mark[root] = Mark::Active;
        while let Some(&mut (v, ref mut next)) = stack.last_mut() {
            if let Some(&w) = consumers[v].get(*next) {
                *next += 1;
                match mark[w] {
                    Mark::New => {
                        mark[w] = Mark::Active;
                        stack.push((w, 0));
                    }
                    Mark::Active => {
                        let start = stack.iter().position(|&(s, _)| s == w).expect("active node is on the stack");
                        let mut cycle: Vec<usize> = stack[start..].iter().map(|&(s, _)| s).collect();
                        cycle.push(w);
                        cycles.push(cycle);
                    }
                    Mark::Done => {}
                }
            } else {
                mark[v] = Mark::Done;
                stack.pop();
            }
        }
    }
    cycles
}

#[cfg(test)]
mod tests {
    use super::{check_output_path, edit_distance, suggest, suggest_close};

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("loadhdr", "loadhdr"), 0);
        assert_eq!(edit_distance("loadhrd", "loadhdr"), 2);
        assert_eq!(edit_distance("", "abc"), 3);
    }

    #[test]
    fn suggestions_name_the_closest() {
        assert_eq!(suggest("pth", &["path", "flip_vertical"], "fields"), "; did you mean \"path\"?");
        assert_eq!(suggest("zzzzzz", &["path"], "fields"), " (fields: path)");
        // A message that lists the choices itself does not list them twice.
        assert_eq!(suggest_close("Filmic", &["Reinhard", "Aces", "Agx"]), "");
        assert_eq!(suggest_close("Acse", &["Reinhard", "Aces", "Agx"]), "; did you mean \"Aces\"?");
    }

    #[test]
    fn output_paths_stay_inside() {
        assert!(check_output_path("a.png").is_ok());
        assert!(check_output_path("sub/a.png").is_ok());
        assert!(check_output_path("../a.png").is_err());
        assert!(check_output_path("sub/../../a.png").is_err());
        assert!(check_output_path("/etc/passwd").is_err());
        assert!(check_output_path("").is_err());
    }
}
