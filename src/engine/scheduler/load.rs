//! Step 3 of a run (see the module doc of `scheduler`): the run's lease on the cache, the plan
//! with the cached values loaded (a corrupt entry sends its node back to `Computed`), and the
//! loaded and provided values put into their slots.

use std::collections::BTreeSet;
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use super::execute::{match_ports, Matched};
use super::plan::plan_status;
use super::state::{node_report, State, Timing};
use super::{NodeStatus, Observer};
use crate::engine::cache::store::Lease;
use crate::engine::cache::{CacheStore, Key};
use crate::engine::error::RunError;
use crate::engine::graph::Pipeline;
use crate::engine::op::Outputs;

/// The cache as a run uses it.
pub(super) struct OpenCache<'a> {
    pub store: Option<&'a CacheStore>,
    /// Held for the run: pruning by other processes spares what it uses.
    pub _lease: Option<Lease>,
    /// The lease could not be taken but the folder exists: read it, store nothing.
    pub read_only: bool,
}

/// Takes the run's lease on the cache, which is also the check that the folder can be written:
/// if it cannot be taken, one warning, and the run reads the cache (a shared, read-only cache
/// still serves its entries) but stores nothing; without the folder, it runs without a cache.
pub(super) fn open_cache<'a>(cache: Option<&'a CacheStore>, obs: &dyn Observer) -> OpenCache<'a> {
    match cache.map(|c| (c, c.lease())) {
        Some((c, Ok(lease))) => OpenCache { store: Some(c), _lease: Some(lease), read_only: false },
        Some((c, Err(e))) if c.root().is_dir() => {
            obs.warning(&format!("{e}; reading the cache at {} but storing nothing in it", c.root().display()));
            OpenCache { store: Some(c), _lease: None, read_only: true }
        }
        Some((_, Err(e))) => {
            obs.warning(&format!("{e}; running without the cache"));
            OpenCache { store: None, _lease: None, read_only: false }
        }
        None => OpenCache { store: None, _lease: None, read_only: false },
    }
}

/// Plans the run and loads the `Cached` nodes' values, in parallel; an entry that cannot be
/// read or no longer matches its node's ports is reported, distrusted, and the plan made again
/// without it. An entry without a port the plan's computed nodes or the caller (`kept`) read is
/// a miss too; one without a port nothing reads serves, with a placeholder there. Returns the final status and each loaded node's values; the load times go into
/// `timing`.
pub(super) fn plan_and_load(
    p: &Pipeline,
    targets: &[usize],
    kept: &[Vec<bool>],
    keys: &[Option<Key>],
    cache: Option<&CacheStore>,
    timing: &[Mutex<Timing>],
    obs: &dyn Observer,
) -> (Vec<NodeStatus>, Vec<Option<Matched>>) {
    let n = p.nodes.len();
    let mut distrust = BTreeSet::new();
    let mut loaded: Vec<Option<Matched>> = (0..n).map(|_| None).collect();
    loop {
        let status = plan_status(p, targets, keys, cache, &distrust);
        let read = super::plan::read_ports(p, kept, &status);
        let to_load: Vec<usize> = (0..n).filter(|&i| status[i] == NodeStatus::Cached && loaded[i].is_none()).collect();
        let results: Vec<(usize, Result<Matched, String>, f64)> = to_load
            .par_iter()
            .map(|&i| {
                let t0 = Instant::now();
                let key = keys[i].expect("needed nodes are keyed");
                let r = match cache.expect("cached implies a cache").get(&key, &p.registry) {
                    // An entry without a port this run may read (an open port that an older
                    // run did not produce, a port no node read then) is a plain miss.
                    Ok(Some(outputs)) => match_ports(p, i, Outputs(outputs), &|k| read[i][k]).map_err(|e| {
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
        // A node loaded without a port that a node this plan computes reads (its entry was
        // stored by a run that did not read it) is computed instead.
        for i in 0..n {
            let lacks = |m: &Matched| m.values.iter().enumerate().any(|(k, v)| v.is_absent() && read[i][k]);
            if status[i] == NodeStatus::Cached && loaded[i].as_ref().is_some_and(lacks) {
                loaded[i] = None;
                failed.push(i);
            }
        }
        if failed.is_empty() {
            return (status, loaded);
        }
        distrust.extend(failed);
    }
}

/// Puts the loaded values (their files into the output folder) and the caller's provided
/// values into their slots, reporting each node.
pub(super) fn fill_slots(s: &State, status: &[NodeStatus], loaded: Vec<Option<Matched>>) -> Result<(), RunError> {
    let obs = s.options.observer;
    for (i, matched) in loaded.into_iter().enumerate() {
        if let Some(Matched { values, extra }) = matched {
            if s.is_target[i] {
                s.target_extras.lock().expect("extras lock").extend(extra.into_iter().map(|(n, v)| (i, n, v)));
            }
            s.store(i, values)?;
            obs.node_finished(&s.report(i, NodeStatus::Cached));
        }
    }
    for (&i, value) in &s.p.provided {
        if status[i] == NodeStatus::Provided {
            s.store(i, vec![value.clone()])?;
            obs.node_finished(&node_report(s.p, i, NodeStatus::Provided, Timing::default(), s.keys));
        }
    }
    Ok(())
}
