//! The shared phase of a batch (step 4 of the module doc of `batch`): the node keys that several
//! items would compute, computed once before the items run.
//!
//! "Shared" has one meaning throughout (the progress line, the bar and the summary): a distinct
//! node key that the plans of two or more items would compute. Each is computed exactly once:
//! a job per item asks for the shared nodes its own nodes consume (its frontier), and a shared
//! node inside the shared part that two jobs would both need is asked for too (so stored) by
//! the first of them, instead of being recomputed by the second.

use std::collections::{BTreeSet, HashMap, HashSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use crate::engine::cache::{key_hex, CacheStore, Key};
use crate::engine::graph::Pipeline;
use crate::engine::scheduler::{self, NodeReport, NodeStatus, Observer, Plan, RunOptions};

/// What the shared phase runs.
pub(super) struct SharedPhase {
    /// Per job: the item whose pipeline runs it and the nodes it asks for.
    pub jobs: Vec<(usize, Vec<String>)>,
    /// How many items' plans compute each key (1 for an item's own nodes).
    pub uses: HashMap<Key, usize>,
    /// The shared keys (`uses > 1`).
    pub keys: BTreeSet<Key>,
}

/// The keys `plan` computes.
pub(super) fn computed_keys(plan: &Plan) -> BTreeSet<Key> {
    (0..plan.status.len()).filter(|&i| plan.status[i] == NodeStatus::Computed).filter_map(|i| plan.keys[i]).collect()
}

/// Plans the shared phase of items whose pipelines, plans and targets are given (an item
/// without a plan failed to plan and is left to fail when it runs).
pub(super) fn plan(pipelines: &[Pipeline], plans: &[Option<Plan>], targets: &[Vec<String>]) -> SharedPhase {
    let mut uses: HashMap<Key, usize> = HashMap::new();
    for plan in plans.iter().flatten() {
        for k in computed_keys(plan) {
            *uses.entry(k).or_default() += 1;
        }
    }
    let keys: BTreeSet<Key> = uses.iter().filter(|(_, &n)| n > 1).map(|(k, _)| *k).collect();

    // Per job: its frontier (claimed by the first item that has it), and every shared node it
    // computes to get there.
    let mut claimed: BTreeSet<Key> = BTreeSet::new();
    let mut jobs: Vec<(usize, Vec<usize>, BTreeSet<usize>)> = Vec::new();
    for (k, plan) in plans.iter().enumerate() {
        let Some(plan) = plan else { continue };
        let p = &pipelines[k];
        let shared =
            |i: usize| plan.status[i] == NodeStatus::Computed && plan.keys[i].is_some_and(|key| keys.contains(&key));
        let frontier: Vec<usize> = (0..plan.status.len())
            .filter(|&i| shared(i))
            .filter(|&i| {
                targets[k].contains(&p.nodes[i].name)
                    || p.consumers(i).into_iter().any(|c| plan.status[c] == NodeStatus::Computed && !shared(c))
            })
            .filter(|&i| plan.keys[i].is_some_and(|key| claimed.insert(key)))
            .collect();
        if frontier.is_empty() {
            continue;
        }
        let mut inside = BTreeSet::new();
        let mut stack = frontier.clone();
        while let Some(i) = stack.pop() {
            if inside.insert(i) {
                stack.extend(p.nodes[i].sources().map(|s| s.node).filter(|&s| shared(s)));
            }
        }
        jobs.push((k, frontier, inside));
    }

    // A key inside several jobs is asked for by the first: stored there, loaded by the rest.
    let mut jobs_with: HashMap<Key, usize> = HashMap::new();
    for (k, _, inside) in &jobs {
        for &i in inside {
            if let Some(key) = plans[*k].as_ref().and_then(|plan| plan.keys[i]) {
                *jobs_with.entry(key).or_default() += 1;
            }
        }
    }
    let mut asked: BTreeSet<Key> = BTreeSet::new();
    let jobs = jobs
        .into_iter()
        .map(|(k, frontier, inside)| {
            let plan = plans[k].as_ref().expect("jobs come from planned items");
            let mut nodes: BTreeSet<usize> = frontier.into_iter().collect();
            for i in inside {
                if let Some(key) = plan.keys[i] {
                    if jobs_with.get(&key).copied().unwrap_or(0) > 1 && asked.insert(key) {
                        nodes.insert(i);
                    }
                }
            }
            (k, nodes.into_iter().map(|i| pipelines[k].nodes[i].name.clone()).collect())
        })
        .collect();
    SharedPhase { jobs, uses, keys }
}

/// Counts the shared keys computed so far, across the phase's jobs.
struct Count<'a> {
    keys: &'a HashSet<String>,
    done: &'a Mutex<HashSet<String>>,
    progress: &'a (dyn Fn(usize) + Sync),
}

impl Observer for Count<'_> {
    fn node_finished(&self, report: &NodeReport) {
        if report.status == NodeStatus::Computed && self.keys.contains(&report.key) {
            let done = {
                let mut done = self.done.lock().expect("shared progress lock");
                done.insert(report.key.clone());
                done.len()
            };
            (self.progress)(done);
        }
    }
}

/// Runs the phase's jobs one at a time on `threads` threads, into each job's item folder
/// (`out_dir(k)`); `progress` gets the count of shared keys computed so far. Returns the node
/// evaluations. A job that fails is its item's failure, reported when that item runs; a set
/// `cancel` stops between jobs.
pub(super) fn run(
    phase: &SharedPhase,
    pipelines: &[Pipeline],
    cache: &CacheStore,
    threads: usize,
    out_dir: &dyn Fn(usize) -> std::path::PathBuf,
    progress: &(dyn Fn(usize) + Sync),
    cancel: Option<&AtomicBool>,
) -> usize {
    let keys: HashSet<String> = phase.keys.iter().map(key_hex).collect();
    let done = Mutex::new(HashSet::new());
    let count = Count { keys: &keys, done: &done, progress };
    let mut evaluations = 0;
    for (k, names) in &phase.jobs {
        if cancel.is_some_and(|c| c.load(Ordering::SeqCst)) {
            break;
        }
        let options = RunOptions {
            targets: names.clone(),
            out_dir: out_dir(*k),
            // What the items will load must be stored even past the limit: evicting or
            // skipping it would make every item recompute it.
            cache: Some(cache.fork().with_add_limit(u64::MAX)),
            jobs: Some(threads),
            observer: &count,
        };
        if let Ok(o) = scheduler::run(&pipelines[*k], &options) {
            evaluations += o.report.count(NodeStatus::Computed);
        }
    }
    evaluations
}
