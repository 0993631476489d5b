//! Steps 1 and 2 of a run (see the module doc of `scheduler`): every ancestor of the targets
//! gets its cache key, inputs first, and the demand-driven plan says which nodes compute,
//! which load from the cache and which are not needed.

use std::collections::BTreeSet;

use rayon::prelude::*;

use super::NodeStatus;
use crate::engine::cache::{node_key, provided_key, CacheStore, Key};
use crate::engine::error::RunError;
use crate::engine::graph::Pipeline;
use crate::engine::op::CheckContext;

/// What a run would do, per node.
#[derive(Clone, Debug)]
pub struct Plan {
    pub targets: Vec<usize>,
    pub keys: Vec<Option<Key>>,
    pub status: Vec<NodeStatus>,
}

pub(super) fn resolve_targets(p: &Pipeline, targets: &[String]) -> Result<Vec<usize>, RunError> {
    if targets.is_empty() {
        return Ok(p.default_targets());
    }
    targets
        .iter()
        .map(|t| {
            p.target_index(t).ok_or_else(|| {
                let names = p.target_names();
                let names: Vec<&str> = names.iter().map(String::as_str).collect();
                RunError::UnknownTarget(t.clone(), crate::engine::graph::suggest(t, &names, "nodes"))
            })
        })
        .collect()
}

/// Per node and port, whether the caller keeps that port's value at the end of the run: every port
/// of a node named as a target (or of a default target), only the named port of a `node.port`
/// target (a node with open ports keeps them all), so that a port the caller does not want is
/// released to its last consumer (which may then reuse its buffer) instead of being held to the end.
pub(super) fn kept_ports(p: &Pipeline, names: &[String], targets: &[usize]) -> Vec<Vec<bool>> {
    let mut kept: Vec<Vec<bool>> = p.nodes.iter().map(|n| vec![false; n.ports.len()]).collect();
    let whole = |kept: &mut Vec<Vec<bool>>, i: usize| kept[i].iter_mut().for_each(|k| *k = true);
    if names.is_empty() {
        targets.iter().for_each(|&i| whole(&mut kept, i));
        return kept;
    }
    for (name, &i) in names.iter().zip(targets) {
        let port = match p.index_of(name) {
            Some(_) => None,
            None => name.rsplit_once('.').and_then(|(_, port)| p.nodes[i].ports.iter().position(|q| q.name == port)),
        };
        match port {
            Some(k) if p.nodes[i].spec.open_ports.is_none() => kept[i][k] = true,
            _ => whole(&mut kept, i),
        }
    }
    kept
}

/// The ports a run reads, given each node's status: those the caller keeps (`kept`) and every
/// input of a node it computes. A node computed in it may leave the others out
/// (`OpContext::wants`); a cache entry without one of these is a miss.
pub(super) fn read_ports(p: &Pipeline, kept: &[Vec<bool>], status: &[NodeStatus]) -> Vec<Vec<bool>> {
    let mut read = kept.to_vec();
    for (i, node) in p.nodes.iter().enumerate() {
        if status[i] == NodeStatus::Computed {
            for s in node.sources() {
                read[s.node][s.port] = true;
            }
        }
    }
    read
}

/// Marks every ancestor of `targets` (inclusive), stopping at provided nodes (their value
/// needs none of their inputs).
fn ancestors(p: &Pipeline, targets: &[usize]) -> Vec<bool> {
    let mut needed = vec![false; p.nodes.len()];
    let mut stack: Vec<usize> = targets.to_vec();
    while let Some(i) = stack.pop() {
        if !needed[i] {
            needed[i] = true;
            if !p.provided.contains_key(&i) {
                stack.extend(p.nodes[i].sources().map(|s| s.node));
            }
        }
    }
    needed
}

/// Cache keys for every ancestor of the targets.
pub fn compute_keys(p: &Pipeline, targets: &[usize]) -> Result<Vec<Option<Key>>, RunError> {
    Ok(compute_keys_and_content(p, targets)?.0)
}

/// Cache keys for every ancestor of the targets, and the content-key bytes of loaders.
#[allow(clippy::type_complexity)]
pub(super) fn compute_keys_and_content(
    p: &Pipeline,
    targets: &[usize],
) -> Result<(Vec<Option<Key>>, Vec<Option<Vec<u8>>>), RunError> {
    let wanted = ancestors(p, targets);
    // Content keys (file hashes) first, in parallel.
    let content: Vec<Option<Vec<u8>>> = (0..p.nodes.len())
        .into_par_iter()
        .map(|i| {
            let node = &p.nodes[i];
            match (wanted[i] && !p.provided.contains_key(&i), &node.spec.content_key) {
                (true, Some(f)) => {
                    let (input_types, input_sizes) = p.input_shapes(i);
                    let ctx = CheckContext {
                        params: &node.params,
                        input_types: &input_types,
                        input_sizes: &input_sizes,
                        base_dir: &p.base_dir,
                        savers: p.registry.savers(),
                    };
                    f(&ctx).map(Some).map_err(|source| RunError::Op {
                        node: node.name.clone(),
                        op: node.spec.name,
                        source,
                    })
                }
                _ => Ok(None),
            }
        })
        .collect::<Result<_, _>>()?;
    let mut keys: Vec<Option<Key>> = vec![None; p.nodes.len()];
    for &i in &p.topo_order {
        if !wanted[i] {
            continue;
        }
        if let Some(value) = p.provided.get(&i) {
            keys[i] = Some(provided_key(value));
            continue;
        }
        let node = &p.nodes[i];
        let inputs: Vec<Vec<(Key, &str)>> = node
            .inputs
            .iter()
            .map(|w| {
                w.sources
                    .iter()
                    .map(|s| {
                        let key = keys[s.node].expect("inputs are keyed first");
                        (key, p.nodes[s.node].ports[s.port].name.as_ref())
                    })
                    .collect()
            })
            .collect();
        keys[i] = Some(node_key(node, &inputs, content[i].as_deref()));
    }
    Ok((keys, content))
}

/// Plans a run: which nodes compute, which come from the cache, which are not needed.
pub fn plan(p: &Pipeline, targets: &[String], cache: Option<&CacheStore>) -> Result<Plan, RunError> {
    let targets = resolve_targets(p, targets)?;
    let keys = compute_keys(p, &targets)?;
    let status = plan_status(p, &targets, &keys, cache, &BTreeSet::new());
    Ok(Plan { targets, keys, status })
}

pub(super) fn plan_status(
    p: &Pipeline,
    targets: &[usize],
    keys: &[Option<Key>],
    cache: Option<&CacheStore>,
    distrust: &BTreeSet<usize>,
) -> Vec<NodeStatus> {
    let mut needed = vec![false; p.nodes.len()];
    for &t in targets {
        needed[t] = true;
    }
    let mut status = vec![NodeStatus::NotNeeded; p.nodes.len()];
    for &i in p.topo_order.iter().rev() {
        if !needed[i] {
            continue;
        }
        if p.provided.contains_key(&i) {
            status[i] = NodeStatus::Provided;
            continue;
        }
        let cached = !distrust.contains(&i)
            && match (cache, keys[i]) {
                (Some(c), Some(k)) => c.contains(&k),
                _ => false,
            };
        if cached {
            status[i] = NodeStatus::Cached;
        } else {
            status[i] = NodeStatus::Computed;
            for s in p.nodes[i].sources() {
                needed[s.node] = true;
            }
        }
    }
    status
}
