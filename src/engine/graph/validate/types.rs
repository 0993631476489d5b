//! Phase 6: in topological order, each input receives a type its field accepts, the operator's
//! own check runs, and each output port gets its type and, when known, its size.

use std::collections::BTreeMap;
use std::path::Path;

use super::fields::Resolved;
use super::{Collector, PortName, RawNode};
use crate::engine::graph::syntax::Pos;
use crate::engine::graph::Port;
use crate::engine::op::{check_pixels, CheckContext, OpSpec, OutputType};
use crate::engine::params::FieldKind;
use crate::engine::save::Savers;
use crate::engine::value::ValueType;

/// Phase 6: types in topological order.
/// A node whose own checks cannot run (in error in phase 4, `broken`, or with an input of a
/// wrong or unknown type) gets only the ports whose type is fixed ([`fixed_ports`]): its
/// consumers are then checked as usual, since their own problems (a saver's extension) do not
/// depend on it. When a port's type depends on the node's fields or inputs, the node keeps no
/// ports, and the inputs it feeds are skipped as "reported already".
pub(super) fn infer_types(
    resolved: &mut Resolved,
    raw: &[RawNode],
    topo_order: &[usize],
    base_dir: &Path,
    savers: &Savers,
    errs: &mut Collector,
) {
    let Resolved { nodes, refs, port_names, broken } = resolved;
    let source = errs.source;
    for &i in topo_order {
        let spec = nodes[i].spec.clone();
        if broken[i] {
            nodes[i].ports = fixed_ports(&spec, &port_names[i]);
            continue;
        }
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
            nodes[i].ports = fixed_ports(&spec, &port_names[i]);
            continue;
        }
        let input_sizes: BTreeMap<&'static str, Vec<Option<(u64, u64)>>> = nodes[i]
            .inputs
            .iter()
            .map(|w| (w.field, w.sources.iter().map(|s| nodes[s.node].port_size(s.port)).collect()))
            .collect();
        let ctx = CheckContext {
            params: &nodes[i].params,
            input_types: &input_types,
            input_sizes: &input_sizes,
            base_dir,
            savers,
        };
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

/// The ports of a node whose checks could not run, when every one of them has a type that does
/// not depend on the node's fields or inputs (declared `Fixed`, or an open port); else none.
fn fixed_ports(spec: &OpSpec, names: &[PortName]) -> Vec<Port> {
    names
        .iter()
        .map(|name| {
            let ty = match spec.port(name) {
                Some(p) => match &p.ty {
                    OutputType::Fixed(t) => Some(*t),
                    OutputType::Computed(..) => None,
                },
                None => spec.open_ports.as_ref().map(|o| o.ty),
            };
            ty.map(|ty| Port { name: name.clone(), ty })
        })
        .collect::<Option<Vec<Port>>>()
        .unwrap_or_default()
}
