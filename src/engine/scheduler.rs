//! Planning and running a validated pipeline.
//!
//! 1. **Keys.** Every ancestor of the targets gets its cache key, inputs first (loaders hash
//!    their file's content, in parallel).
//! 2. **Plan** (demand-driven, from the targets back): a needed node whose key is in the cache
//!    is `Cached` and its inputs are not needed for its sake; otherwise it is `Compute` and its
//!    inputs are needed. Everything else is `Skipped` (not needed by the targets).
//! 3. **Load** the cached values. An entry that turns out corrupt is reported, dropped, and the
//!    plan is made again without it, so that node and whatever it needs are computed.
//! 4. **Run** the `Compute` nodes on a rayon pool: a node starts as soon as its inputs are
//!    ready, so independent nodes run at once, and operators use the same pool for their own
//!    data parallelism. Each result is stored in the cache as soon as it exists.
//! 5. **Outputs.** File values (from `Save`) are written into the output folder atomically, and
//!    only when their bytes differ from what is already there.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use rayon::prelude::*;

use crate::engine::cache::store::{remove_stale_temporaries, write_atomic};
use crate::engine::cache::{key_hex, node_key, CacheStore, Key};
use crate::engine::error::RunError;
use crate::engine::graph::Pipeline;
use crate::engine::op::OpContext;
use crate::engine::value::Value;

/// What happens to a node in a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum NodeStatus {
    Computed,
    Cached,
    /// Not needed by the targets (or only needed by a node served from the cache).
    Skipped,
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
    /// Hex cache key ("" when the node was not needed at all).
    pub key: String,
}

/// The report of a run (`--report FILE` writes it as JSON).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RunReport {
    pub total_ms: f64,
    pub nodes: Vec<NodeReport>,
    /// Files written into the output folder (unchanged files are not rewritten nor listed).
    #[serde(skip)]
    pub written: Vec<PathBuf>,
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

/// A finished run: its report and the targets' values.
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
    targets.iter().map(|t| p.index_of(t).ok_or_else(|| RunError::UnknownTarget(t.clone()))).collect()
}

/// Marks every ancestor of `targets` (inclusive).
fn ancestors(p: &Pipeline, targets: &[usize]) -> Vec<bool> {
    let mut needed = vec![false; p.nodes.len()];
    let mut stack: Vec<usize> = targets.to_vec();
    while let Some(i) = stack.pop() {
        if !needed[i] {
            needed[i] = true;
            stack.extend(p.nodes[i].inputs.values().copied());
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
            match (wanted[i], node.spec.content_key) {
                (true, Some(f)) => f(&node.params, &p.base_dir).map(Some).map_err(|source| RunError::Op {
                    node: node.name.clone(),
                    op: node.spec.name,
                    source,
                }),
                _ => Ok(None),
            }
        })
        .collect::<Result<_, _>>()?;
    let mut keys: Vec<Option<Key>> = vec![None; p.nodes.len()];
    for &i in &p.topo_order {
        if !wanted[i] {
            continue;
        }
        let node = &p.nodes[i];
        let input_keys: BTreeMap<&'static str, Key> =
            node.inputs.iter().map(|(f, &j)| (*f, keys[j].expect("inputs are keyed first"))).collect();
        keys[i] = Some(node_key(node, &input_keys, content[i].as_deref()));
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
    let mut status = vec![NodeStatus::Skipped; p.nodes.len()];
    for &i in p.topo_order.iter().rev() {
        if !needed[i] {
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
            for &j in p.nodes[i].inputs.values() {
                needed[j] = true;
            }
        }
    }
    status
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

fn run_in_pool(p: &Pipeline, options: &RunOptions) -> Result<RunOutcome, RunError> {
    let start = Instant::now();
    let obs = options.observer;
    let cache = options.cache.as_ref();
    let targets = resolve_targets(p, &options.targets)?;
    let (keys, content) = compute_keys_and_content(p, &targets)?;
    let n = p.nodes.len();

    let values: Vec<OnceLock<Value>> = (0..n).map(|_| OnceLock::new()).collect();
    let ms: Vec<Mutex<f64>> = (0..n).map(|_| Mutex::new(0.0)).collect();
    let written: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

    // Plan, then load cached values; a corrupt entry sends its node back to `Computed`.
    let mut distrust = BTreeSet::new();
    let status = loop {
        let status = plan_status(p, &targets, &keys, cache, &distrust);
        let to_load: Vec<usize> =
            (0..n).filter(|&i| status[i] == NodeStatus::Cached && values[i].get().is_none()).collect();
        let failed: Vec<usize> = to_load
            .par_iter()
            .filter_map(|&i| {
                let t0 = Instant::now();
                let key = keys[i].expect("needed nodes are keyed");
                match cache.expect("cached implies a cache").get(&key) {
                    Ok(Some(v)) => {
                        let _ = values[i].set(v);
                        *ms[i].lock().expect("timing lock") = t0.elapsed().as_secs_f64() * 1e3;
                        None
                    }
                    Ok(None) => Some(i),
                    Err(e) => {
                        obs.warning(&format!("node {:?}: {e}; recomputing", p.nodes[i].name));
                        Some(i)
                    }
                }
            })
            .collect();
        if failed.is_empty() {
            break status;
        }
        distrust.extend(failed);
    };
    let compute: Vec<usize> = (0..n).filter(|&i| status[i] == NodeStatus::Computed).collect();
    obs.planned(compute.len(), status.iter().filter(|s| **s == NodeStatus::Cached).count());

    // Cached file values still have to exist in the output folder.
    for i in 0..n {
        if status[i] == NodeStatus::Cached {
            if let Some(Value::File(f)) = values[i].get() {
                if let Some(path) = write_output(&options.out_dir, &f.rel_path, &f.bytes)? {
                    written.lock().expect("written lock").push(path);
                }
            }
        }
    }
    for i in 0..n {
        if status[i] == NodeStatus::Cached {
            obs.node_finished(&node_report(p, i, NodeStatus::Cached, *ms[i].lock().expect("timing lock"), &keys));
        }
    }

    // Dependency counts among the nodes to compute.
    let is_compute: Vec<bool> = (0..n).map(|i| status[i] == NodeStatus::Computed).collect();
    let pending: Vec<AtomicUsize> =
        (0..n).map(|i| AtomicUsize::new(p.nodes[i].inputs.values().filter(|&&j| is_compute[j]).count())).collect();
    let consumers: Vec<Vec<usize>> =
        (0..n).map(|i| p.consumers(i).into_iter().filter(|&c| is_compute[c]).collect()).collect();
    let abort = AtomicBool::new(false);
    let first_error: Mutex<Option<RunError>> = Mutex::new(None);

    struct Shared<'s> {
        p: &'s Pipeline,
        options: &'s RunOptions<'s>,
        keys: &'s [Option<Key>],
        content: &'s [Option<Vec<u8>>],
        values: &'s [OnceLock<Value>],
        ms: &'s [Mutex<f64>],
        pending: &'s [AtomicUsize],
        consumers: &'s [Vec<usize>],
        abort: &'s AtomicBool,
        first_error: &'s Mutex<Option<RunError>>,
        written: &'s Mutex<Vec<PathBuf>>,
    }

    fn execute<'s>(s: &'s Shared<'s>, scope: &rayon::Scope<'s>, i: usize) {
        if s.abort.load(Ordering::SeqCst) {
            return;
        }
        let node = &s.p.nodes[i];
        let obs = s.options.observer;
        obs.node_started(&node.name);
        let t0 = Instant::now();
        let inputs: BTreeMap<&'static str, Value> = node
            .inputs
            .iter()
            .map(|(f, &j)| (*f, s.values[j].get().expect("inputs finish before consumers").clone()))
            .collect();
        let ctx = OpContext {
            node: &node.name,
            params: &node.params,
            inputs: &inputs,
            base_dir: &s.p.base_dir,
            content_key: s.content[i].as_deref(),
        };
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (node.spec.eval)(&ctx)));
        let outcome = match result {
            Ok(Ok(v)) => Ok(v),
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
        let value = match outcome.and_then(|v| {
            if let Value::File(f) = &v {
                if let Some(path) = write_output(&s.options.out_dir, &f.rel_path, &f.bytes)? {
                    s.written.lock().expect("written lock").push(path);
                }
            }
            Ok(v)
        }) {
            Ok(v) => v,
            Err(e) => {
                s.abort.store(true, Ordering::SeqCst);
                s.first_error.lock().expect("error lock").get_or_insert(e);
                return;
            }
        };
        if let (Some(cache), Some(key)) = (&s.options.cache, s.keys[i]) {
            if let Err(e) = cache.put(&key, &value) {
                obs.warning(&format!("node {:?}: could not store its result in the cache: {e}", node.name));
            }
        }
        let _ = s.values[i].set(value);
        let elapsed = t0.elapsed().as_secs_f64() * 1e3;
        *s.ms[i].lock().expect("timing lock") = elapsed;
        obs.node_finished(&node_report(s.p, i, NodeStatus::Computed, elapsed, s.keys));
        for &c in &s.consumers[i] {
            if s.pending[c].fetch_sub(1, Ordering::SeqCst) == 1 {
                scope.spawn(move |scope| execute(s, scope, c));
            }
        }
    }

    let shared = Shared {
        p,
        options,
        keys: &keys,
        content: &content,
        values: &values,
        ms: &ms,
        pending: &pending,
        consumers: &consumers,
        abort: &abort,
        first_error: &first_error,
        written: &written,
    };
    rayon::scope(|scope| {
        for &i in &compute {
            if pending[i].load(Ordering::SeqCst) == 0 {
                let s = &shared;
                scope.spawn(move |scope| execute(s, scope, i));
            }
        }
    });
    if let Some(e) = first_error.into_inner().expect("error lock") {
        return Err(e);
    }

    let nodes = (0..n).map(|i| node_report(p, i, status[i], *ms[i].lock().expect("timing lock"), &keys)).collect();
    let target_values =
        targets.iter().filter_map(|&t| values[t].get().map(|v| (p.nodes[t].name.clone(), v.clone()))).collect();
    let mut written = written.into_inner().expect("written lock");
    written.sort();
    Ok(RunOutcome {
        report: RunReport { total_ms: start.elapsed().as_secs_f64() * 1e3, nodes, written },
        values: target_values,
    })
}

fn node_report(p: &Pipeline, i: usize, status: NodeStatus, ms: f64, keys: &[Option<Key>]) -> NodeReport {
    NodeReport {
        name: p.nodes[i].name.clone(),
        op: p.nodes[i].spec.name,
        status,
        ms,
        key: keys[i].map(|k| key_hex(&k)).unwrap_or_default(),
    }
}

/// Writes one output file unless identical bytes are already there. Returns the path if written.
fn write_output(out_dir: &Path, rel: &str, bytes: &[u8]) -> Result<Option<PathBuf>, RunError> {
    check_output_path(rel).map_err(|_| RunError::PathEscape(rel.to_string()))?;
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

#[cfg(test)]
mod tests {
    use super::check_output_path;

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
