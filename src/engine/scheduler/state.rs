//! What the workers of a run share (steps 4 and 5 of the module doc of `scheduler`): each output
//! port's slot with the count of consumers it still waits for, the queue of ready nodes with the
//! run's count of bytes held (`admission`), and the files and errors the run collects.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use super::admission::Admission;
use super::output::write_output;
use super::{NodeReport, NodeStatus, PortReport, RunOptions};
use crate::engine::cache::{key_hex, CacheStore, Key};
use crate::engine::error::RunError;
use crate::engine::graph::Pipeline;
use crate::engine::value::{FileBlob, Value};

/// One output port's value while the run holds it, and how many consumers it still waits for.
pub(super) struct Slot {
    pub value: Mutex<Option<Value>>,
    pub remaining: AtomicUsize,
}

/// Per-node timing for the report.
#[derive(Clone, Copy, Default)]
pub(super) struct Timing {
    pub ms: f64,
    pub start_ms: f64,
    pub thread: Option<usize>,
    /// Its results are in the cache (loaded from it, or stored after computing).
    pub stored: bool,
    /// What a later run would spend to get its results back without the cache: its own
    /// compute time plus that of every input chain not stored either (see `cache::policy`).
    pub recompute_ms: f64,
}

/// The release counts: per node and port, the consumers that will take its value (one per
/// input edge of a computed node, so a node reading a port twice counts twice), plus one if
/// the caller keeps the port (`kept`: it takes those values at the end). A port whose count is 0
/// is dropped as soon as it is produced.
pub(super) fn release_counts(p: &Pipeline, is_compute: &[bool], kept: &[Vec<bool>]) -> Vec<Vec<usize>> {
    let mut counts: Vec<Vec<usize>> =
        kept.iter().map(|ports| ports.iter().map(|&k| usize::from(k)).collect()).collect();
    for (i, node) in p.nodes.iter().enumerate() {
        if is_compute[i] {
            for s in node.sources() {
                counts[s.node][s.port] += 1;
            }
        }
    }
    counts
}

/// Everything the workers share.
pub(super) struct State<'a> {
    pub p: &'a Pipeline,
    pub options: &'a RunOptions<'a>,
    pub cache: Option<&'a CacheStore>,
    /// Storing failed once (or the cache is read-only): nothing more is stored.
    pub cache_failed: AtomicBool,
    /// The run's add limit was reached and said so.
    pub limit_warned: AtomicBool,
    pub start: Instant,
    pub keys: &'a [Option<Key>],
    pub content: &'a [Option<Vec<u8>>],
    pub slots: Vec<Vec<Slot>>,
    pub timing: Vec<Mutex<Timing>>,
    /// Per node, the computed inputs it still waits for (an input edge each).
    pub pending: Vec<AtomicUsize>,
    /// Per node, the computed nodes that consume it.
    pub consumers: Vec<Vec<usize>>,
    pub abort: AtomicBool,
    pub first_error: Mutex<Option<RunError>>,
    pub written: Mutex<Vec<PathBuf>>,
    pub files: Mutex<Vec<(String, String)>>,
    pub ready: Admission,
    pub is_target: Vec<bool>,
    /// The open ports targets produced that no consumer names (kept for the caller: a
    /// `SplitChannels` target returns every channel).
    pub target_extras: Mutex<Vec<(usize, String, Value)>>,
}

impl State<'_> {
    /// Bytes of the values node `i` is the last consumer of.
    pub fn frees(&self, i: usize) -> usize {
        let node = &self.p.nodes[i];
        let mut bytes = 0;
        for src in node.sources() {
            let uses = node.sources().filter(|s| *s == src).count();
            let slot = &self.slots[src.node][src.port];
            if slot.remaining.load(Ordering::SeqCst) == uses {
                if let Some(v) = slot.value.lock().expect("slot lock").as_ref() {
                    bytes += v.approx_bytes() / uses;
                }
            }
        }
        bytes
    }

    pub fn fail(&self, e: RunError) {
        self.abort.store(true, Ordering::SeqCst);
        self.first_error.lock().expect("error lock").get_or_insert(e);
    }

    /// Stores a node's outputs in its port slots (ports nothing waits for are dropped), after
    /// writing its files into the output folder. A file is kept as its paths only
    /// ([`FileBlob::written`]): its bytes are on disk, and a large one (a 4096 cube's chain is
    /// 1 GB) is not held to the end of the run for a caller that reads only where it went.
    pub fn store(&self, i: usize, outputs: Vec<Value>) -> Result<(), RunError> {
        for (port, mut value) in outputs.into_iter().enumerate() {
            if let Some(f) = value.get::<FileBlob>() {
                for (rel_path, bytes) in f.files() {
                    self.files.lock().expect("files lock").push((self.p.nodes[i].name.clone(), rel_path.to_string()));
                    if let Some(path) = write_output(&self.options.out_dir, rel_path, bytes)? {
                        self.written.lock().expect("written lock").push(path);
                    }
                }
                value = Value::new(f.written());
            }
            let slot = &self.slots[i][port];
            if slot.remaining.load(Ordering::SeqCst) > 0 {
                let node = &self.p.nodes[i];
                let shape = if node.is_default_port(port) { super::output_shape(node) } else { None };
                self.ready.stored(value.approx_bytes(), shape);
                *slot.value.lock().expect("slot lock") = Some(value);
            }
        }
        Ok(())
    }

    /// Consumer `i`'s copy of port `port` of node `j`: the value itself for the last consumer,
    /// so the run's reference is gone once it has started (the value is then counted as held by
    /// `i` until it finishes or releases it).
    pub fn acquire(&self, i: usize, j: usize, port: usize) -> Value {
        let slot = &self.slots[j][port];
        let mut guard = slot.value.lock().expect("slot lock");
        let left = slot.remaining.fetch_sub(1, Ordering::SeqCst) - 1;
        if left == 0 {
            let value = guard.take().expect("a port's value stays until its last consumer");
            self.ready.took(i, value.approx_bytes());
            value
        } else {
            guard.clone().expect("a port's value stays until its last consumer")
        }
    }

    /// Running node `i` hands back input value `v` before finishing (`OpContext::release`): it is
    /// dropped now, and no longer counted as held if `i` took it as its last consumer (no slot of
    /// `i`'s inputs still holds it).
    pub fn release(&self, i: usize, v: Value) {
        let in_a_slot = self.p.nodes[i].sources().any(|src| {
            let slot = self.slots[src.node][src.port].value.lock().expect("slot lock");
            slot.as_ref().is_some_and(|held| held.ptr_eq(&v))
        });
        let bytes = if in_a_slot { 0 } else { v.approx_bytes() };
        drop(v);
        self.ready.released(i, bytes);
    }

    /// Node `i`'s line in the report.
    pub fn report(&self, i: usize, status: NodeStatus) -> NodeReport {
        let t = *self.timing[i].lock().expect("timing lock");
        node_report(self.p, i, status, t, self.keys)
    }
}

pub(super) fn node_report(p: &Pipeline, i: usize, status: NodeStatus, t: Timing, keys: &[Option<Key>]) -> NodeReport {
    NodeReport {
        name: p.nodes[i].name.clone(),
        op: p.nodes[i].spec.name,
        status,
        ms: t.ms,
        start_ms: t.start_ms,
        thread: t.thread,
        key: keys[i].map(|k| key_hex(&k)).unwrap_or_default(),
        ports: p.nodes[i].ports.iter().map(|port| PortReport { name: port.name.clone(), ty: port.ty.name() }).collect(),
        stored: t.stored,
    }
}
