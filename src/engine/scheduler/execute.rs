//! Step 4 of a run (see the module doc of `scheduler`): a node starts as soon as its inputs
//! are ready, runs its operator, and hands its results to the cache, its slots and its
//! consumers.

use std::sync::atomic::Ordering;
use std::time::Instant;

use super::state::{State, Timing};
use super::NodeStatus;
use crate::engine::cache::{aux_key, policy, CacheStore};
use crate::engine::context::AuxStore;
use crate::engine::error::{CacheError, RunError};
use crate::engine::graph::Pipeline;
use crate::engine::op::OpSpec;
use crate::engine::op::{OpContext, Outputs};
use crate::engine::registry::Registry;
use crate::engine::value::{Absent, FileBlob, Value};

/// A node's outputs matched to its ports, and what else it produced (open ports no consumer
/// names: cached, so that a later pipeline naming them is served, but not kept in memory).
pub(super) struct Matched {
    pub values: Vec<Value>,
    pub extra: Vec<(String, Value)>,
}

/// Orders an operator's (or a cache entry's) outputs by the node's ports and checks each
/// against its declared type. The unnamed output is the default port. A port missing from
/// `outputs` that nothing reads (`read(k)` false: the operator skipped it, `OpContext::wants`)
/// gets an [`Absent`] placeholder; one that is read is an error ("no output ...").
pub(super) fn match_ports(
    p: &Pipeline,
    i: usize,
    outputs: Outputs,
    read: &dyn Fn(usize) -> bool,
) -> Result<Matched, String> {
    let node = &p.nodes[i];
    let mut outputs = outputs.0;
    // The common case, one output for one port: no lookups.
    if outputs.len() == 1 && node.ports.len() == 1 && (outputs[0].0.is_empty() || outputs[0].0 == node.ports[0].name) {
        let (_, value) = outputs.pop().expect("one output");
        check_type(node, 0, &value)?;
        return Ok(Matched { values: vec![value], extra: Vec::new() });
    }
    let default = node.spec.outputs.first().map(|p| p.name);
    let mut slots: Vec<Option<Value>> = vec![None; node.ports.len()];
    let mut extra = Vec::new();
    for (name, value) in outputs {
        let name = if name.is_empty() { default.unwrap_or_default().to_string() } else { name };
        match node.ports.iter().position(|p| p.name == name) {
            Some(k) => slots[k] = Some(value),
            None if node.spec.open_ports.is_some() || node.spec.port(&name).is_some() => extra.push((name, value)),
            None => return Err(format!("it produced an output {name:?} that {} does not declare", node.spec.name)),
        }
    }
    let mut values = Vec::with_capacity(slots.len());
    for (k, slot) in slots.into_iter().enumerate() {
        let value = match slot {
            Some(value) => value,
            None if !read(k) => Value::new(Absent(node.ports[k].ty)),
            None => return Err(format!("no output {:?} was produced", node.ports[k].name)),
        };
        check_type(node, k, &value)?;
        values.push(value);
    }
    Ok(Matched { values, extra })
}

fn check_type(node: &crate::engine::graph::Node, k: usize, value: &Value) -> Result<(), String> {
    let port = &node.ports[k];
    if value.value_type() != port.ty {
        return Err(format!(
            "output {:?} is a {}, but {} declares {}",
            port.name,
            value.value_type(),
            node.spec.name,
            port.ty
        ));
    }
    Ok(())
}

/// Queues a node whose inputs are ready and spawns a task that starts the best queued node
/// that may start at the time it runs (see `admission`).
pub(super) fn enqueue<'s>(s: &'s State<'s>, scope: &rayon::Scope<'s>, i: usize) {
    s.ready.push(i, s.frees(i));
    pump(s, scope);
}

/// Spawns a task that starts the best queued node that may start, if any. Called whenever that
/// may have changed: a node queued, finished, or an input released early. A task that starts a
/// node spawns another while nodes are queued, so an idle worker takes the next.
pub(super) fn pump<'s>(s: &'s State<'s>, scope: &rayon::Scope<'s>) {
    scope.spawn(move |scope| {
        if let Some(next) = s.ready.pop() {
            if s.ready.has_queued() {
                pump(s, scope);
            }
            execute(s, scope, next);
            pump(s, scope);
        }
    });
}

/// Runs node `i`: takes its inputs, evaluates it (a panic is an error of that node), checks
/// its outputs, stores them in the cache if worth it and in its slots, queues every consumer
/// that was waiting only for it, then counts it as finished.
fn execute<'s>(s: &'s State<'s>, scope: &rayon::Scope<'s>, i: usize) {
    if s.abort.load(Ordering::SeqCst) {
        return s.ready.finished(i);
    }
    let node = &s.p.nodes[i];
    let obs = s.options.observer;
    obs.node_started(&node.name);
    let t0 = Instant::now();
    let start_ms = t0.duration_since(s.start).as_secs_f64() * 1e3;
    let release = move |v: Value| {
        s.release(i, v);
        pump(s, scope);
    };
    let Matched { values, extra } = match evaluate(s, i, &release) {
        Ok(m) => m,
        Err(e) => {
            s.ready.finished(i);
            return s.fail(e);
        }
    };
    let compute_ms = t0.elapsed().as_secs_f64() * 1e3;
    let recompute_ms = compute_ms + unstored_inputs_ms(s, i);
    let stored = store_in_cache(s, i, &values, &extra, recompute_ms);
    if s.is_target[i] {
        s.target_extras.lock().expect("extras lock").extend(extra.into_iter().map(|(n, v)| (i, n, v)));
    }
    if let Err(e) = s.store(i, values) {
        s.ready.finished(i);
        return s.fail(e);
    }
    let elapsed = t0.elapsed().as_secs_f64() * 1e3;
    *s.timing[i].lock().expect("timing lock") =
        Timing { ms: elapsed, start_ms, thread: rayon::current_thread_index(), stored, recompute_ms };
    obs.node_finished(&s.report(i, NodeStatus::Computed));
    for &c in &s.consumers[i] {
        let waits = s.p.nodes[c].sources().filter(|src| src.node == i).count();
        if s.pending[c].fetch_sub(waits, Ordering::SeqCst) == waits {
            enqueue(s, scope, c);
        }
    }
    // Counted as finished only now that its consumers are queued: were it before, another
    // worker could find nothing running and start a large node ahead of them (see `admission`).
    s.ready.finished(i);
}

/// Node `i`'s operator on its inputs, with its warnings reported and its outputs matched to
/// its ports. The inputs are dropped before it returns: a value whose last consumer this was is
/// freed here.
fn evaluate(s: &State, i: usize, release: &(dyn Fn(Value) + Sync)) -> Result<Matched, RunError> {
    let node = &s.p.nodes[i];
    let inputs: Vec<(&'static str, Vec<Value>)> = node
        .inputs
        .iter()
        .map(|w| (w.field, w.sources.iter().map(|src| s.acquire(i, src.node, src.port)).collect()))
        .collect();
    let open_ports: Vec<String> =
        node.ports.iter().filter(|p| node.spec.port(&p.name).is_none()).map(|p| p.name.to_string()).collect();
    // A port is read when a consumer that runs, or the caller, takes it: its release count.
    let read = |k: usize| s.slots[i][k].remaining.load(Ordering::SeqCst) > 0;
    let unread_ports: Vec<&str> =
        node.ports.iter().enumerate().filter(|&(k, _)| !read(k)).map(|(_, p)| &*p.name).collect();
    let aux = s.cache.map(|cache| CacheAux { cache, registry: &s.p.registry, spec: &node.spec });
    let mut ctx = OpContext {
        node: &node.name,
        params: &node.params,
        inputs,
        base_dir: &s.p.base_dir,
        content_key: s.content[i].as_deref(),
        wanted_ports: &open_ports,
        unread_ports: &unread_ports,
        savers: s.p.registry.savers(),
        warnings: Vec::new(),
        release_to: Some(release),
        aux: aux.as_ref().map(|a| a as &dyn AuxStore),
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (node.spec.eval)(&mut ctx)));
    for w in std::mem::take(&mut ctx.warnings) {
        s.options.observer.warning(&format!("node {:?}: {w}", node.name));
    }
    drop(ctx);
    match result {
        Ok(Ok(outputs)) => match_ports(s.p, i, outputs, &read).map_err(|m| RunError::Contract {
            node: node.name.clone(),
            op: node.spec.name,
            message: m,
        }),
        Ok(Err(source)) => Err(RunError::Op { node: node.name.clone(), op: node.spec.name, source }),
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            Err(RunError::Panic(format!("node {:?} ({}): {msg}", node.name, node.spec.name)))
        }
    }
}

/// The run's cache as an operator's store of its own data ([`AuxStore`]): an entry of one `aux`
/// port holding the bytes as a file value, under [`aux_key`].
struct CacheAux<'a> {
    cache: &'a CacheStore,
    registry: &'a Registry,
    spec: &'a OpSpec,
}

impl CacheAux<'_> {
    fn key(&self, name: &str) -> crate::engine::cache::Key {
        aux_key(self.spec.name, self.spec.version, &self.spec.code_hash, name)
    }
}

impl AuxStore for CacheAux<'_> {
    fn load(&self, name: &str) -> Option<Vec<u8>> {
        let outputs = self.cache.get(&self.key(name), self.registry).ok()??;
        let (_, value) = outputs.into_iter().find(|(port, _)| port == "aux")?;
        value.take::<FileBlob>().map(|blob| blob.bytes)
    }

    fn save(&self, name: &str, bytes: Vec<u8>) {
        let blob = Value::new(FileBlob::new(name.to_string(), bytes));
        // A failure (the run's cache limit, a full disk) only means making the data again.
        let _ = self.cache.put(&self.key(name), &[("aux".to_string(), blob)]);
    }
}

/// The recompute time of node `i`'s inputs that are not in the cache (each input node once).
fn unstored_inputs_ms(s: &State, i: usize) -> f64 {
    let mut counted = Vec::new();
    let mut ms = 0.0;
    for src in s.p.nodes[i].sources() {
        if !counted.contains(&src.node) {
            counted.push(src.node);
            let t = s.timing[src.node].lock().expect("timing lock");
            if !t.stored {
                ms += t.recompute_ms;
            }
        }
    }
    ms
}

/// Stores node `i`'s results if the persistence policy finds them worth it; true if stored.
/// A failure is one warning for the run (not one per node), then nothing more is stored.
fn store_in_cache(s: &State, i: usize, values: &[Value], extra: &[(String, Value)], recompute_ms: f64) -> bool {
    let (Some(cache), Some(key)) = (s.cache, s.keys[i]) else { return false };
    let node = &s.p.nodes[i];
    let bytes = values.iter().chain(extra.iter().map(|(_, v)| v)).map(|v| v.approx_bytes() as u64).sum();
    let worth = policy::worth_storing(cache.policy(), node.spec.persist, s.is_target[i], recompute_ms, bytes);
    if !worth || s.cache_failed.load(Ordering::Relaxed) {
        return false;
    }
    // A port not computed (nothing read it) is left out: a run that reads it misses the entry.
    let mut named: Vec<(String, Value)> = node
        .ports
        .iter()
        .zip(values)
        .filter(|(_, v)| !v.is_absent())
        .map(|(p, v)| (p.name.to_string(), v.clone()))
        .collect();
    named.extend(extra.iter().cloned());
    let obs = s.options.observer;
    match cache.put(&key, &named) {
        Ok(()) => true,
        // Past the run's add limit: this entry is skipped, smaller ones may still fit.
        Err(e @ CacheError::LimitReached { .. }) => {
            if !s.limit_warned.swap(true, Ordering::SeqCst) {
                obs.warning(&format!("{e}; results past it are not stored"));
            }
            false
        }
        Err(e) => {
            if !s.cache_failed.swap(true, Ordering::SeqCst) {
                obs.warning(&format!("could not store results in the cache ({e}); going on without storing"));
            }
            false
        }
    }
}
