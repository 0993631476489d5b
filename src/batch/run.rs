//! Running a validated batch: the shared phase, then the items `jobs` at a time, with the cache
//! folder pruned as they end (steps 3 to 6 of the module doc of `batch`).

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use super::items::Item;
use super::shared;
use crate::engine::cache::{CacheStore, Key};
use crate::engine::graph::{Override, Pipeline};
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions, Silent};
use crate::values::Metrics;

/// How an item ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ItemStatus {
    /// At least one of its nodes had to be computed.
    Computed,
    /// Every node it needed was in the cache when the batch started.
    Cached,
    Failed,
}

impl ItemStatus {
    pub fn word(self) -> &'static str {
        match self {
            ItemStatus::Computed => "computed",
            ItemStatus::Cached => "cached",
            ItemStatus::Failed => "failed",
        }
    }
}

/// One item's row in the batch report.
#[derive(Clone, Debug)]
pub struct ItemRow {
    pub item: Item,
    pub status: ItemStatus,
    pub ms: f64,
    pub error: Option<String>,
    /// `node.field` (or `node.port.field`) of every Metrics value its targets produced.
    pub metrics: Vec<(String, f64)>,
    /// Nodes this item's own run computed.
    pub evaluations: usize,
}

/// Progress events of a batch.
pub trait BatchObserver: Sync {
    /// The shared phase starts: `nodes` distinct nodes that several items would compute are
    /// computed once, first (see `shared`).
    fn shared_phase(&self, _nodes: usize) {}
    /// `done` of the shared phase's `total` nodes are computed.
    fn shared_progress(&self, _done: usize, _total: usize) {}
    fn item_started(&self, _item: &Item) {}
    fn item_finished(&self, _row: &ItemRow) {}
}

/// How to run a batch.
pub struct BatchOptions<'a> {
    pub out_dir: PathBuf,
    pub cache: CacheStore,
    /// The cache folder is kept within this many bytes while the batch runs (see step 6).
    pub cache_limit_bytes: u64,
    /// Worker threads in all (None: one per core); up to this many items run at once.
    pub jobs: Option<usize>,
    pub keep_going: bool,
    pub observer: &'a dyn BatchObserver,
    /// Set from outside (the CLI's Ctrl-C handler): no further item starts; running ones finish.
    pub cancel: Option<&'a AtomicBool>,
}

/// A finished batch.
pub struct BatchOutcome {
    pub rows: Vec<ItemRow>,
    /// Node evaluations in all (shared phase included), against items x nodes.
    pub evaluations: usize,
    /// Of them, the shared phase's: each shared node once (fewer if a job failed or the batch
    /// was cancelled).
    pub shared_evaluations: usize,
    pub item_nodes: usize,
    pub total_ms: f64,
    /// Items not started because an earlier one failed (without `keep_going`), or because the
    /// batch was cancelled.
    pub not_started: usize,
    /// `cancel` was set before every item had started.
    pub cancelled: bool,
}

fn overrides(item: &Item) -> Vec<Override> {
    item.values
        .iter()
        .map(|(label, value)| {
            let (node, field) = label.rsplit_once('.').expect("labels are NODE.FIELD");
            Override { node: node.into(), field: field.into(), value: value.clone() }
        })
        .collect()
}

/// Validates every item's pipeline; all errors at once, each prefixed with its item.
pub fn validate(registry: &Registry, graph: &Path, items: &[Item]) -> Result<Vec<Pipeline>, Vec<String>> {
    let mut out = Vec::new();
    let mut errors = Vec::new();
    for it in items {
        match Pipeline::load(graph, registry, &overrides(it)) {
            Ok(p) => out.push(p),
            Err(e) => errors.extend(e.0.iter().map(|e| format!("item {:?}: {e}", it.dir))),
        }
    }
    if errors.is_empty() {
        Ok(out)
    } else {
        Err(errors)
    }
}

/// The targets of an item: the default targets plus the nodes whose metrics they save (so a
/// `Save` of `diff.metrics` puts its numbers in the report).
fn targets(p: &Pipeline) -> Vec<String> {
    let metrics = |n: usize| p.nodes[n].ports.iter().any(|port| port.ty.name() == "metrics");
    let mut t: BTreeSet<usize> = p.default_targets().into_iter().collect();
    for &i in t.clone().iter() {
        for s in p.nodes[i].sources() {
            if metrics(s.node) {
                t.insert(s.node);
            }
        }
    }
    t.into_iter().map(|i| p.nodes[i].name.clone()).collect()
}

/// Runs a validated batch (`pipelines[k]` is `items[k]`'s).
pub fn run(items: &[Item], pipelines: &[Pipeline], options: &BatchOptions) -> BatchOutcome {
    let start = Instant::now();
    let threads = options.jobs.filter(|&j| j > 0).unwrap_or_else(rayon::current_num_threads).max(1);
    let at_once = threads.min(items.len()).max(1);
    let per_item = (threads / at_once).max(1);
    let cache = &options.cache;

    // Plans: an item is `cached` if nothing of it needs computing now. Keys several items
    // would compute are computed first, once.
    let plans: Vec<Option<scheduler::Plan>> =
        pipelines.iter().map(|p| scheduler::plan(p, &targets(p), Some(cache)).ok()).collect();
    let item_targets: Vec<Vec<String>> = pipelines.iter().map(targets).collect();
    let phase = shared::plan(pipelines, &plans, &item_targets);
    // Shared keys stay pinned against pruning until every item that needs them has ended (the
    // folder may exceed the limit by them: they are what the batch cannot do without).
    let pinned: Mutex<HashMap<Key, usize>> = Mutex::new(phase.keys.iter().map(|k| (*k, phase.uses[k])).collect());
    let prune_lock = Mutex::new(());
    let prune = || {
        let _one_at_a_time = prune_lock.lock().expect("prune lock");
        let pins: BTreeSet<Key> = pinned.lock().expect("pinned lock").keys().copied().collect();
        // Pruning is housekeeping: a failure leaves the folder larger, the results are unchanged.
        let _ = cache.prune_sparing(options.cache_limit_bytes, &|k| pins.contains(k));
    };
    let mut shared_evaluations = 0;
    if !phase.jobs.is_empty() {
        let total = phase.keys.len();
        options.observer.shared_phase(total);
        shared_evaluations = shared::run(
            &phase,
            pipelines,
            cache,
            threads,
            &|k| options.out_dir.join(&items[k].dir),
            &|done| options.observer.shared_progress(done, total),
            options.cancel,
        );
        prune();
    }

    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let rows: Mutex<Vec<Option<ItemRow>>> = Mutex::new(vec![None; items.len()]);
    let evaluations = AtomicUsize::new(0);
    std::thread::scope(|s| {
        for _ in 0..at_once {
            s.spawn(|| loop {
                if stop.load(Ordering::SeqCst) || options.cancel.is_some_and(|c| c.load(Ordering::SeqCst)) {
                    break;
                }
                let k = next.fetch_add(1, Ordering::SeqCst);
                if k >= items.len() {
                    break;
                }
                let item = &items[k];
                let p = &pipelines[k];
                options.observer.item_started(item);
                let t0 = Instant::now();
                let item_cache = cache.fork();
                let run_options = RunOptions {
                    targets: item_targets[k].clone(),
                    out_dir: options.out_dir.join(&item.dir),
                    cache: Some(item_cache.clone()),
                    jobs: Some(per_item),
                    observer: &Silent,
                };
                let row = match scheduler::run(p, &run_options) {
                    Ok(outcome) => {
                        let computed = outcome.report.count(NodeStatus::Computed);
                        evaluations.fetch_add(computed, Ordering::SeqCst);
                        let was_cached =
                            plans[k].as_ref().is_some_and(|plan| !plan.status.contains(&NodeStatus::Computed));
                        let mut metrics = Vec::new();
                        for (label, v) in &outcome.values {
                            if let Some(m) = v.get::<Metrics>() {
                                metrics.extend(m.fields.iter().map(|(f, x)| (format!("{label}.{f}"), *x)));
                            }
                        }
                        ItemRow {
                            item: item.clone(),
                            status: if was_cached && computed == 0 { ItemStatus::Cached } else { ItemStatus::Computed },
                            ms: t0.elapsed().as_secs_f64() * 1e3,
                            error: None,
                            metrics,
                            evaluations: computed,
                        }
                    }
                    Err(e) => {
                        if !options.keep_going {
                            stop.store(true, Ordering::SeqCst);
                        }
                        ItemRow {
                            item: item.clone(),
                            status: ItemStatus::Failed,
                            ms: t0.elapsed().as_secs_f64() * 1e3,
                            error: Some(e.to_string()),
                            metrics: Vec::new(),
                            evaluations: 0,
                        }
                    }
                };
                if let Some(plan) = &plans[k] {
                    let mut pins = pinned.lock().expect("pinned lock");
                    for key in shared::computed_keys(plan) {
                        if let Some(n) = pins.get_mut(&key) {
                            *n -= 1;
                            if *n == 0 {
                                pins.remove(&key);
                            }
                        }
                    }
                }
                // The folder only grew if the item stored something (scanning it is not free).
                if item_cache.added_bytes() > 0 {
                    prune();
                }
                options.observer.item_finished(&row);
                rows.lock().expect("rows lock")[k] = Some(row);
            });
        }
    });
    let all = rows.into_inner().expect("rows lock");
    let not_started = all.iter().filter(|r| r.is_none()).count();
    let rows: Vec<ItemRow> = all.into_iter().flatten().collect();
    let item_nodes = pipelines.iter().map(|p| p.nodes.len()).sum();
    BatchOutcome {
        rows,
        evaluations: evaluations.into_inner() + shared_evaluations,
        shared_evaluations,
        item_nodes,
        total_ms: start.elapsed().as_secs_f64() * 1e3,
        not_started,
        cancelled: not_started > 0 && options.cancel.is_some_and(|c| c.load(Ordering::SeqCst)),
    }
}
