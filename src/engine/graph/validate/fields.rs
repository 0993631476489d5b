//! Phase 4: each field is known, parameters convert to their kind and range, inputs name
//! existing nodes and ports with the declared arity, and defaults fill the rest.

use std::collections::{BTreeMap, HashMap};

use super::convert::convert;
use super::suggest::{did_you_mean, suggest, suggest_field};
use super::{Collector, PortName, RawNode, WrittenRef};
use crate::engine::graph::syntax::{Pos, Ron, Spanned};
use crate::engine::graph::{InputWire, Node, PortRef};
use crate::engine::params::{Arity, FieldKind, Params};

/// What phase 4 produces: every node that phase 2 accepted, with its parameters and wiring (port
/// indices into `port_names`), the written position of every reference, each node's port names,
/// and which nodes are in error (reported here; the later phases skip their own checks, so that
/// one bad node neither hides the other nodes' problems nor cascades into more errors).
pub(super) struct Resolved {
    pub nodes: Vec<Node>,
    pub refs: Vec<BTreeMap<&'static str, Vec<WrittenRef>>>,
    pub port_names: Vec<Vec<PortName>>,
    pub broken: Vec<bool>,
}

/// Phase 4: fields, parameters, references and defaults.
pub(super) fn resolve_fields(
    raw: &[RawNode],
    all_names: &HashMap<String, Pos>,
    source: &str,
    errs: &mut Collector,
) -> Resolved {
    let index: HashMap<&str, usize> = raw.iter().enumerate().map(|(i, n)| (n.name.as_str(), i)).collect();
    let node_names: Vec<&str> = raw.iter().map(|n| n.name.as_str()).collect();
    // Port names per node: the declared ones first; open ports are appended as consumers name them.
    let mut port_names: Vec<Vec<PortName>> =
        raw.iter().map(|n| n.spec.outputs.iter().map(|p| PortName::Borrowed(p.name)).collect()).collect();
    let mut nodes = Vec::with_capacity(raw.len());
    let mut all_refs = Vec::with_capacity(raw.len());
    let mut broken = Vec::with_capacity(raw.len());
    for n in raw {
        let mut ok = true;
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
                    format!("{} has no field {:?}{}", n.spec.name, fname.value, suggest_field(&fname.value, &fields)),
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
        broken.push(!ok);
    }
    Resolved { nodes, refs: all_refs, port_names, broken }
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
