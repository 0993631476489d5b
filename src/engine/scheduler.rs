//! Planning and running a validated pipeline.
//!
//! 1. **Keys.** Every ancestor of the targets gets its cache key, inputs first (loaders hash
//!    their file's content, in parallel).
//! 2. **Plan** (demand-driven, from the targets back): a needed node whose key is in the cache
//!    is `Cached` and its inputs are not needed for its sake; otherwise it is `Computed` and its
//!    inputs are needed. Everything else is `NotNeeded`. A node whose value the caller supplied
//!    (`Pipeline::provide`) is `Provided`: keyed by the value's content, never evaluated, and
//!    its inputs are not needed for its sake.
//! 3. **Load** the cached values. An entry that turns out corrupt is reported, dropped, and the
//!    plan is made again without it, so that node and whatever it needs are computed.
//! 4. **Run** the `Computed` nodes on a rayon pool: a node starts as soon as its inputs are
//!    ready, so independent nodes run at once, and operators use the same pool for their own
//!    data parallelism. Each result is checked against its declared type and stored in the cache
//!    as soon as it exists.
//! 5. **Memory.** Among the nodes ready to start, the one that frees the most memory goes
//!    first (the bytes of the inputs it is the last consumer of). Every output port counts the consumers still to start (plus one if its node
//!    is a target). A consumer takes a clone of the value, and the last one takes the value
//!    itself, so the engine's reference is gone as soon as the last consumer has started and
//!    the value is freed when that consumer finishes with it; an operator that is the last
//!    consumer of an input can reuse its buffer (`OpContext::take`). Ports nothing consumes are
//!    dropped as soon as they are produced (after the cache has stored them).
//! 6. **Outputs.** File values (from `Save`) are written into the output folder atomically, and
//!    only when their bytes differ from what is already there. The folder is checked (created,
//!    a folder, writable) before anything is computed.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use crate::engine::cache::store::{remove_stale_temporaries, write_atomic};
use crate::engine::cache::{key_hex, node_key, policy, provided_key, CacheStore, Key};
use crate::engine::error::{CacheError, RunError};
use crate::engine::graph::Pipeline;
use crate::engine::op::{CheckContext, OpContext, Outputs};
use crate::engine::value::{FileBlob, Value};

/// What happens to a node in a run. The same three words everywhere: the table, the summary,
/// `plan`, the JSON report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum NodeStatus {
    #[serde(rename = "computed")]
    Computed,
    #[serde(rename = "cached")]
    Cached,
    /// Not needed by the targets (or only needed by a node served from the cache).
    #[serde(rename = "not needed")]
    NotNeeded,
    /// Its value was supplied by the caller (`Pipeline::provide`): not evaluated.
    #[serde(rename = "provided")]
    Provided,
}

impl NodeStatus {
    pub fn word(self) -> &'static str {
        match self {
            NodeStatus::Computed => "computed",
            NodeStatus::Cached => "cached",
            NodeStatus::NotNeeded => "not needed",
            NodeStatus::Provided => "provided",
        }
    }
}

/// Receives progress events. The library never prints; the CLI implements this.
pub trait Observer: Sync {
    /// The plan is known: `compute` nodes will run, `cached` will be loaded.
    fn planned(&self, _compute: usize, _cached: usize) {}
    fn node_started(&self, _name: &str) {}
    fn node_finished(&self, _report: &NodeReport) {}
    fn warning(&self, _message: &str) {}
}

/// An observer that ignores everything.
pub struct Silent;
impl Observer for Silent {}

/// One node's line in a run report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NodeReport {
    pub name: String,
    pub op: &'static str,
    pub status: NodeStatus,
    pub ms: f64,
    /// When the node started, in ms since the run started (0 for nodes not computed).
    pub start_ms: f64,
    /// The worker thread that ran it (None for nodes not computed).
    pub thread: Option<usize>,
    /// Hex cache key ("" when the node was not needed at all).
    pub key: String,
    /// The node's output ports and their value types.
    pub ports: Vec<PortReport>,
    /// Its results are in the cache after the run: loaded from it, or computed and judged worth
    /// storing (see `engine::cache::policy`).
    pub stored: bool,
}

/// One output port of a node in a report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PortReport {
    pub name: std::borrow::Cow<'static, str>,
    #[serde(rename = "type")]
    pub ty: &'static str,
}

/// The report of a run (`--report FILE` writes it as JSON).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RunReport {
    pub total_ms: f64,
    pub nodes: Vec<NodeReport>,
    /// Files written into the output folder (unchanged files are not rewritten nor listed).
    #[serde(skip)]
    pub written: Vec<PathBuf>,
    /// Every file the run's nodes produced, written or already up to date: (node, path relative
    /// to the output folder), sorted.
    #[serde(skip)]
    pub files: Vec<(String, String)>,
}

impl RunReport {
    pub fn count(&self, status: NodeStatus) -> usize {
        self.nodes.iter().filter(|n| n.status == status).count()
    }
    pub fn status_of(&self, name: &str) -> Option<NodeStatus> {
        self.nodes.iter().find(|n| n.name == name).map(|n| n.status)
    }
}

/// How to run.
pub struct RunOptions<'a> {
    /// Target node names; empty means the pipeline's default targets.
    pub targets: Vec<String>,
    pub out_dir: PathBuf,
    pub cache: Option<CacheStore>,
    /// Worker threads (None: rayon's default, one per core).
    pub jobs: Option<usize>,
    pub observer: &'a dyn Observer,
}

/// A finished run: its report and the targets' values, by `node` (the default port) and
/// `node.port` (the others).
pub struct RunOutcome {
    pub report: RunReport,
    pub values: BTreeMap<String, Value>,
}

/// What a run would do, per node.
#[derive(Clone, Debug)]
pub struct Plan {
    pub targets: Vec<usize>,
    pub keys: Vec<Option<Key>>,
    pub status: Vec<NodeStatus>,
}

fn resolve_targets(p: &Pipeline, targets: &[String]) -> Result<Vec<usize>, RunError> {
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
fn compute_keys_and_content(
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

fn plan_status(
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

/// Makes sure `dir` can receive output files: created if missing, a folder, writable.
pub fn check_output_dir(dir: &Path) -> Result<(), RunError> {
    let fail = |reason: String| RunError::OutputDir { path: dir.to_path_buf(), reason };
    if dir.exists() && !dir.is_dir() {
        return Err(fail("it exists and is not a folder".into()));
    }
    std::fs::create_dir_all(dir).map_err(|e| fail(format!("cannot create it: {e}")))?;
    let probe = dir.join(format!(".hdrflow-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(|e| fail(format!("cannot write into it: {e}")))?;
    let _ = std::fs::remove_file(&probe);
    // A run killed between the write and the removal leaves its probe: remove any such leftover
    // (another live run's probe may go too, which is harmless: it has already been written).
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(".hdrflow-write-test-") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    Ok(())
}

/// Runs a pipeline.
pub fn run(p: &Pipeline, options: &RunOptions) -> Result<RunOutcome, RunError> {
    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(n) = options.jobs {
            b = b.num_threads(n.max(1));
        }
        b.build().map_err(|e| RunError::ThreadPool(e.to_string()))?
    };
    pool.install(|| run_in_pool(p, options))
}

/// One output port's value while the run holds it, and how many consumers it still waits for.
struct Slot {
    value: Mutex<Option<Value>>,
    remaining: AtomicUsize,
}

/// Per-node timing for the report.
#[derive(Clone, Copy, Default)]
struct Timing {
    ms: f64,
    start_ms: f64,
    thread: Option<usize>,
    /// Its results are in the cache (loaded from it, or stored after computing).
    stored: bool,
    /// What a later run would spend to get its results back without the cache: its own
    /// compute time plus that of every input chain not stored either (see `cache::policy`).
    recompute_ms: f64,
}

/// Everything the workers share.
struct Shared<'s> {
    p: &'s Pipeline,
    options: &'s RunOptions<'s>,
    cache: Option<&'s CacheStore>,
    cache_failed: &'s AtomicBool,
    limit_warned: &'s AtomicBool,
    start: Instant,
    keys: &'s [Option<Key>],
    content: &'s [Option<Vec<u8>>],
    slots: &'s [Vec<Slot>],
    timing: &'s [Mutex<Timing>],
    pending: &'s [AtomicUsize],
    consumers: &'s [Vec<usize>],
    abort: &'s AtomicBool,
    first_error: &'s Mutex<Option<RunError>>,
    written: &'s Mutex<Vec<PathBuf>>,
    files: &'s Mutex<Vec<(String, String)>>,
    /// Nodes whose inputs are all ready, not yet started, by priority (see `enqueue`). Each
    /// entry has one spawned task that starts the best entry at the time it runs.
    ready: &'s Mutex<BinaryHeap<(usize, Reverse<usize>)>>,
    /// Which nodes are targets, and the open ports they produced that no consumer names (kept
    /// for the caller: a `SplitChannels` target returns every channel).
    is_target: &'s [bool],
    target_extras: &'s Mutex<Vec<(usize, String, Value)>>,
}

impl Shared<'_> {
    /// The ready node to start now (see `enqueue`).
    fn pick(&self) -> Option<usize> {
        self.ready.lock().expect("ready lock").pop().map(|(_, Reverse(i))| i)
    }

    /// Bytes of the values node `i` is the last consumer of.
    fn frees(&self, i: usize) -> usize {
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

    /// Queues a node whose inputs are ready and spawns a task to start the best queued one.
    /// Priority: the memory the node frees by starting (the bytes of the inputs it is the last
    /// consumer of, as of now), then the earliest in file order. Starting such nodes first keeps
    /// large values (a distribution, a full map) alive as briefly as possible; outputs do not
    /// depend on the order. A heap keeps this O(log n) per node for wide graphs.
    fn enqueue<'s>(&'s self, scope: &rayon::Scope<'s>, i: usize) {
        let priority = self.frees(i);
        self.ready.lock().expect("ready lock").push((priority, Reverse(i)));
        scope.spawn(move |scope| {
            if let Some(next) = self.pick() {
                execute(self, scope, next);
            }
        });
    }

    fn fail(&self, e: RunError) {
        self.abort.store(true, Ordering::SeqCst);
        self.first_error.lock().expect("error lock").get_or_insert(e);
    }

    /// Stores a node's outputs in its port slots (ports nothing waits for are dropped), after
    /// writing its files into the output folder.
    fn store(&self, i: usize, outputs: Vec<Value>) -> Result<(), RunError> {
        for (port, value) in outputs.into_iter().enumerate() {
            if let Some(f) = value.get::<FileBlob>() {
                for (rel_path, bytes) in f.files() {
                    self.files.lock().expect("files lock").push((self.p.nodes[i].name.clone(), rel_path.to_string()));
                    if let Some(path) = write_output(&self.options.out_dir, rel_path, bytes)? {
                        self.written.lock().expect("written lock").push(path);
                    }
                }
            }
            let slot = &self.slots[i][port];
            if slot.remaining.load(Ordering::SeqCst) > 0 {
                *slot.value.lock().expect("slot lock") = Some(value);
            }
        }
        Ok(())
    }

    /// A consumer's copy of port `port` of node `j`: the value itself for the last consumer.
    fn acquire(&self, j: usize, port: usize) -> Value {
        let slot = &self.slots[j][port];
        let mut guard = slot.value.lock().expect("slot lock");
        let left = slot.remaining.fetch_sub(1, Ordering::SeqCst) - 1;
        if left == 0 {
            guard.take().expect("a port's value stays until its last consumer")
        } else {
            guard.clone().expect("a port's value stays until its last consumer")
        }
    }
}

fn run_in_pool(p: &Pipeline, options: &RunOptions) -> Result<RunOutcome, RunError> {
    let start = Instant::now();
    let obs = options.observer;
    let targets = resolve_targets(p, &options.targets)?;
    let (keys, content) = compute_keys_and_content(p, &targets)?;
    let n = p.nodes.len();

    // The run's lease on the cache (pruning by other processes spares what it uses) is also the
    // check that the folder can be written: if it cannot be taken, one warning, and the run
    // reads the cache (a shared, read-only cache still serves its entries) but stores nothing.
    let (cache, _lease, read_only) = match options.cache.as_ref().map(|c| (c, c.lease())) {
        Some((c, Ok(lease))) => (Some(c), Some(lease), false),
        Some((c, Err(e))) if c.root().is_dir() => {
            obs.warning(&format!("{e}; reading the cache at {} but storing nothing in it", c.root().display()));
            (Some(c), None, true)
        }
        Some((_, Err(e))) => {
            obs.warning(&format!("{e}; running without the cache"));
            (None, None, false)
        }
        None => (None, None, false),
    };
    let cache_failed = AtomicBool::new(read_only);
    let limit_warned = AtomicBool::new(false);

    let slots: Vec<Vec<Slot>> = p
        .nodes
        .iter()
        .map(|node| {
            node.ports.iter().map(|_| Slot { value: Mutex::new(None), remaining: AtomicUsize::new(0) }).collect()
        })
        .collect();
    let timing: Vec<Mutex<Timing>> = (0..n).map(|_| Mutex::new(Timing::default())).collect();
    let written: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    let files: Mutex<Vec<(String, String)>> = Mutex::new(Vec::new());

    // Plan, then load cached values; a corrupt entry sends its node back to `Computed`.
    let mut distrust = BTreeSet::new();
    let mut loaded: Vec<Option<Matched>> = (0..n).map(|_| None).collect();
    let status = loop {
        let status = plan_status(p, &targets, &keys, cache, &distrust);
        let to_load: Vec<usize> = (0..n).filter(|&i| status[i] == NodeStatus::Cached && loaded[i].is_none()).collect();
        let results: Vec<(usize, Result<Matched, String>, f64)> = to_load
            .par_iter()
            .map(|&i| {
                let t0 = Instant::now();
                let key = keys[i].expect("needed nodes are keyed");
                let r = match cache.expect("cached implies a cache").get(&key, &p.registry) {
                    // An entry without a port this pipeline names (an open port that an older
                    // run did not produce) is a plain miss.
                    Ok(Some(outputs)) => match_ports(p, i, Outputs(outputs)).map_err(|e| {
                        if e.starts_with("no output") {
                            String::new()
                        } else {
                            e
                        }
                    }),
                    Ok(None) => Err(String::new()),
                    Err(e) => Err(e.to_string()),
                };
                (i, r, t0.elapsed().as_secs_f64() * 1e3)
            })
            .collect();
        let mut failed = Vec::new();
        for (i, r, ms) in results {
            match r {
                Ok(values) => {
                    loaded[i] = Some(values);
                    let mut t = timing[i].lock().expect("timing lock");
                    t.ms = ms;
                    t.stored = true;
                }
                Err(e) => {
                    if !e.is_empty() {
                        obs.warning(&format!("node {:?}: {e}; recomputing", p.nodes[i].name));
                    }
                    failed.push(i);
                }
            }
        }
        if failed.is_empty() {
            break status;
        }
        distrust.extend(failed);
    };
    let is_compute: Vec<bool> = (0..n).map(|i| status[i] == NodeStatus::Computed).collect();
    let compute: Vec<usize> = (0..n).filter(|&i| is_compute[i]).collect();
    obs.planned(compute.len(), status.iter().filter(|s| **s == NodeStatus::Cached).count());

    if (0..n).any(|i| status[i] != NodeStatus::NotNeeded && p.nodes[i].writes_file()) {
        check_output_dir(&options.out_dir)?;
    }

    // Consumers still to start, per port: compute nodes' input edges, plus one for targets.
    let is_target: Vec<bool> = {
        let mut t = vec![false; n];
        for &i in &targets {
            t[i] = true;
        }
        t
    };
    for i in 0..n {
        if is_target[i] {
            for slot in &slots[i] {
                slot.remaining.fetch_add(1, Ordering::SeqCst);
            }
        }
        if is_compute[i] {
            for s in p.nodes[i].sources() {
                slots[s.node][s.port].remaining.fetch_add(1, Ordering::SeqCst);
            }
        }
    }

    let pending: Vec<AtomicUsize> =
        (0..n).map(|i| AtomicUsize::new(p.nodes[i].sources().filter(|s| is_compute[s.node]).count())).collect();
    let consumers: Vec<Vec<usize>> =
        (0..n).map(|i| p.consumers(i).into_iter().filter(|&c| is_compute[c]).collect()).collect();
    let abort = AtomicBool::new(false);
    let first_error: Mutex<Option<RunError>> = Mutex::new(None);
    let ready = Mutex::new(BinaryHeap::new());
    let target_extras = Mutex::new(Vec::new());
    let shared = Shared {
        p,
        options,
        cache,
        cache_failed: &cache_failed,
        limit_warned: &limit_warned,
        start,
        keys: &keys,
        content: &content,
        slots: &slots,
        timing: &timing,
        pending: &pending,
        consumers: &consumers,
        abort: &abort,
        first_error: &first_error,
        written: &written,
        files: &files,
        ready: &ready,
        is_target: &is_target,
        target_extras: &target_extras,
    };

    // Cached values go into their slots (their files into the output folder).
    for (i, matched) in loaded.into_iter().enumerate() {
        if let Some(Matched { values, extra }) = matched {
            if is_target[i] {
                target_extras.lock().expect("extras lock").extend(extra.into_iter().map(|(n, v)| (i, n, v)));
            }
            shared.store(i, values)?;
            let t = *timing[i].lock().expect("timing lock");
            obs.node_finished(&node_report(p, i, NodeStatus::Cached, t, &keys));
        }
    }

    // Provided values go into their slots the same way.
    for (&i, value) in &p.provided {
        if status[i] == NodeStatus::Provided {
            shared.store(i, vec![value.clone()])?;
            obs.node_finished(&node_report(p, i, NodeStatus::Provided, Timing::default(), &keys));
        }
    }

    // The nodes with no input to wait for, chosen before any node runs: once the first ones run,
    // they start their consumers themselves, and a consumer whose count reached 0 meanwhile must
    // not be started a second time by this loop.
    let roots: Vec<usize> = compute.iter().copied().filter(|&i| pending[i].load(Ordering::SeqCst) == 0).collect();
    rayon::scope(|scope| {
        for &i in &roots {
            shared.enqueue(scope, i);
        }
    });
    if let Some(e) = first_error.into_inner().expect("error lock") {
        return Err(e);
    }

    let nodes = (0..n).map(|i| node_report(p, i, status[i], *timing[i].lock().expect("timing lock"), &keys)).collect();
    let mut values = BTreeMap::new();
    for &t in &targets {
        for (port, slot) in slots[t].iter().enumerate() {
            if let Some(v) = slot.value.lock().expect("slot lock").take() {
                values.insert(p.nodes[t].port_label(port), v);
            }
        }
    }
    for (t, port, v) in target_extras.into_inner().expect("extras lock") {
        values.insert(format!("{}.{port}", p.nodes[t].name), v);
    }
    let mut written = written.into_inner().expect("written lock");
    written.sort();
    let mut files = files.into_inner().expect("files lock");
    files.sort();
    let report = RunReport { total_ms: start.elapsed().as_secs_f64() * 1e3, nodes, written, files };
    Ok(RunOutcome { report, values })
}

/// A node's outputs matched to its ports, and what else it produced (open ports no consumer
/// names: cached, so that a later pipeline naming them is served, but not kept in memory).
struct Matched {
    values: Vec<Value>,
    extra: Vec<(String, Value)>,
}

/// Orders an operator's (or a cache entry's) outputs by the node's ports and checks each
/// against its declared type. The unnamed output is the default port.
fn match_ports(p: &Pipeline, i: usize, outputs: Outputs) -> Result<Matched, String> {
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
        let Some(value) = slot else {
            return Err(format!("no output {:?} was produced", node.ports[k].name));
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

fn execute<'s>(s: &'s Shared<'s>, scope: &rayon::Scope<'s>, i: usize) {
    if s.abort.load(Ordering::SeqCst) {
        return;
    }
    let node = &s.p.nodes[i];
    let obs = s.options.observer;
    obs.node_started(&node.name);
    let t0 = Instant::now();
    let start_ms = t0.duration_since(s.start).as_secs_f64() * 1e3;
    let inputs: Vec<(&'static str, Vec<Value>)> = node
        .inputs
        .iter()
        .map(|w| (w.field, w.sources.iter().map(|src| s.acquire(src.node, src.port)).collect()))
        .collect();
    let open_ports: Vec<String> =
        node.ports.iter().filter(|p| node.spec.port(&p.name).is_none()).map(|p| p.name.to_string()).collect();
    let mut ctx = OpContext {
        node: &node.name,
        params: &node.params,
        inputs,
        base_dir: &s.p.base_dir,
        content_key: s.content[i].as_deref(),
        wanted_ports: &open_ports,
        warnings: Vec::new(),
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (node.spec.eval)(&mut ctx)));
    for w in std::mem::take(&mut ctx.warnings) {
        obs.warning(&format!("node {:?}: {w}", node.name));
    }
    drop(ctx); // the inputs: a value whose last consumer this was is freed here
    let outcome = match result {
        Ok(Ok(outputs)) => match_ports(s.p, i, outputs).map_err(|m| RunError::Contract {
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
    };
    let Matched { values, extra } = match outcome {
        Ok(v) => v,
        Err(e) => return s.fail(e),
    };
    let compute_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut recompute_ms = compute_ms;
    let mut counted = Vec::new();
    for src in node.sources() {
        if !counted.contains(&src.node) {
            counted.push(src.node);
            let t = s.timing[src.node].lock().expect("timing lock");
            if !t.stored {
                recompute_ms += t.recompute_ms;
            }
        }
    }
    let mut stored = false;
    if let (Some(cache), Some(key)) = (s.cache, s.keys[i]) {
        let bytes = values.iter().chain(extra.iter().map(|(_, v)| v)).map(|v| v.approx_bytes() as u64).sum();
        let worth = policy::worth_storing(cache.policy(), node.spec.persist, s.is_target[i], recompute_ms, bytes);
        if worth && !s.cache_failed.load(Ordering::Relaxed) {
            let mut named: Vec<(String, Value)> =
                node.ports.iter().zip(&values).map(|(p, v)| (p.name.to_string(), v.clone())).collect();
            named.extend(extra.iter().cloned());
            match cache.put(&key, &named) {
                Ok(()) => stored = true,
                // Past the run's add limit: this entry is skipped, smaller ones may still fit.
                Err(e @ CacheError::LimitReached { .. }) => {
                    if !s.limit_warned.swap(true, Ordering::SeqCst) {
                        obs.warning(&format!("{e}; results past it are not stored"));
                    }
                }
                // One warning for the run, not one per node.
                Err(e) => {
                    if !s.cache_failed.swap(true, Ordering::SeqCst) {
                        obs.warning(&format!("could not store results in the cache ({e}); going on without storing"));
                    }
                }
            }
        }
    }
    if s.is_target[i] {
        s.target_extras.lock().expect("extras lock").extend(extra.into_iter().map(|(n, v)| (i, n, v)));
    }
    if let Err(e) = s.store(i, values) {
        return s.fail(e);
    }
    let elapsed = t0.elapsed().as_secs_f64() * 1e3;
    let t = Timing { ms: elapsed, start_ms, thread: rayon::current_thread_index(), stored, recompute_ms };
    *s.timing[i].lock().expect("timing lock") = t;
    obs.node_finished(&node_report(s.p, i, NodeStatus::Computed, t, s.keys));
    for &c in &s.consumers[i] {
        let waits = s.p.nodes[c].sources().filter(|src| src.node == i).count();
        if s.pending[c].fetch_sub(waits, Ordering::SeqCst) == waits {
            s.enqueue(scope, c);
        }
    }
}

fn node_report(p: &Pipeline, i: usize, status: NodeStatus, t: Timing, keys: &[Option<Key>]) -> NodeReport {
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

/// Writes one output file unless identical bytes are already there. Returns the path if written.
fn write_output(out_dir: &Path, rel: &str, bytes: &[u8]) -> Result<Option<PathBuf>, RunError> {
    crate::engine::graph::check_output_path(rel).map_err(|_| RunError::PathEscape(rel.to_string()))?;
    let path = out_dir.join(rel);
    remove_stale_temporaries(&path);
    if let Ok(existing) = std::fs::metadata(&path) {
        if existing.len() == bytes.len() as u64 && std::fs::read(&path).map(|b| b == bytes).unwrap_or(false) {
            return Ok(None);
        }
    }
    write_atomic(&path, bytes).map_err(|source| RunError::Output { path: path.clone(), source })?;
    Ok(Some(path))
}
