//! Batch runs: one pipeline over a library of maps and parameter sweeps (`hdrflow batch`).
//!
//! 1. **Items.** Every `--over NODE.FIELD=GLOB_OR_LIST` and `--sweep NODE.FIELD=V1,V2,...` is an
//!    axis of values; the items are their cross product (first axis outermost), or with `zip`
//!    their pairing. Each item has an index (its position in the whole list, before sharding)
//!    and a folder from a template. Two items in one folder is an error before anything runs.
//! 2. **Shards.** `--shard I/N` keeps the items whose index is congruent to I mod N: the N
//!    shards are disjoint and cover every item, and round-robin spreads a sweep's costly values
//!    over all shards.
//! 3. **Validation.** Every item's pipeline (the file with the item's values as overrides) is
//!    validated before any runs.
//! 4. **Shared nodes first.** Each item is planned against the cache; a node key that several
//!    items would compute (anything not downstream of the swept field: a Fresnel plot, a sample
//!    set, one map's distribution under a sweep of counts) is computed once, in a first phase
//!    that runs those nodes one item at a time on the whole pool. In the second phase every item
//!    runs and finds them in the cache, so items running at once never compute the same key. A
//!    shared `Save` runs in the first phase too, into the folder of the first item that has it;
//!    the others load it from the cache and write their own copy.
//! 5. **Items** run `jobs` at a time, each on its own pool of `threads / jobs` threads, and each
//!    item's values are dropped when it ends (only its metrics stay): the batch never holds more
//!    items' values than it runs at once.
//! 6. **Disk.** Each computed result is stored or not by the cache's persistence policy
//!    (`engine::cache::policy`: huge cheap intermediates are not). After each item the cache
//!    folder is pruned to `cache_limit_bytes`, least recently used first, sparing the entries
//!    of items still running (their leases) and the shared entries that items yet to finish
//!    will load; each item may add at most that much itself.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::data::Metrics;
use crate::engine::cache::{CacheStore, Key};
use crate::engine::graph::{Override, Pipeline};
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions, Silent};

/// One axis of a batch: a field and the values it takes.
#[derive(Clone, Debug)]
pub struct Axis {
    pub node: String,
    pub field: String,
    pub values: Vec<String>,
    /// From `--over` (values are usually paths: `{stem}` comes from the first such axis).
    pub over: bool,
}

impl Axis {
    /// Parses `NODE.FIELD=V1,V2,...` (`(0,1,0),(1,0,0)` is two tuples). For `--over`, each
    /// value with `*`, `?` or `[` is a glob, replaced by its matching files, sorted
    /// (`maps/*_1k.hdr,extra/one.hdr` is every match, then the one file).
    pub fn parse(s: &str, over: bool) -> Result<Axis, String> {
        let flag = if over { "--over" } else { "--sweep" };
        let o = Override::parse(s).map_err(|e| e.replace("--set", flag))?;
        let mut values = Vec::new();
        for item in split_list(&o.value) {
            if !(over && item.contains(['*', '?', '['])) {
                values.push(item);
                continue;
            }
            let mut matches = Vec::new();
            for entry in glob::glob(&item).map_err(|e| format!("{flag} {s:?}: bad pattern {item:?}: {e}"))? {
                let path = entry.map_err(|e| format!("{flag} {s:?}: {e}"))?;
                if path.is_file() {
                    matches.push(path.display().to_string());
                }
            }
            if matches.is_empty() {
                return Err(format!("{flag} {s:?}: no file matches {item:?}"));
            }
            matches.sort();
            values.extend(matches);
        }
        if values.iter().any(|v| v.is_empty()) {
            return Err(format!("{flag} {s:?}: an empty value"));
        }
        Ok(Axis { node: o.node, field: o.field, values, over })
    }

    pub fn label(&self) -> String {
        format!("{}.{}", self.node, self.field)
    }
}

/// Splits a comma-separated list at the commas outside brackets and quotes (`(0,1,0),(1,0,0)`
/// is two tuples).
fn split_list(s: &str) -> Vec<String> {
    let mut out = Vec::new();
    let (mut depth, mut quoted, mut cur) = (0i32, false, String::new());
    for c in s.chars() {
        match c {
            '"' => quoted = !quoted,
            '(' | '[' if !quoted => depth += 1,
            ')' | ']' if !quoted => depth -= 1,
            ',' if !quoted && depth == 0 => {
                out.push(cur.trim().to_string());
                cur.clear();
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    out.push(cur.trim().to_string());
    out
}

/// One item of a batch.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Item {
    /// Position in the whole batch (before sharding).
    pub index: usize,
    /// The item's folder, relative to the batch's output folder (also its name in reports).
    pub dir: String,
    /// `NODE.FIELD` and value, one per axis.
    pub values: Vec<(String, String)>,
}

/// The default folder template: `{stem}` of the first `--over`, then `FIELD={FIELD}` parts for
/// the other axes (`NODE.FIELD=` when two axes share a field name).
pub fn default_template(axes: &[Axis]) -> String {
    let mut parts = Vec::new();
    let first_over = axes.iter().position(|a| a.over);
    for (i, a) in axes.iter().enumerate() {
        if Some(i) == first_over {
            parts.push("{stem}".to_string());
        } else {
            let shared = axes.iter().filter(|b| b.field == a.field).count() > 1;
            let name = if shared { a.label() } else { a.field.clone() };
            parts.push(format!("{name}={{{}}}", a.label()));
        }
    }
    parts.join("/")
}

/// A value as a folder-name part: `--over` paths (a `/` or a letters-only extension) give
/// their stem; anything but letters, digits and
/// `.-_+=` becomes `_`.
fn path_part(value: &str, over: bool) -> String {
    let has_ext =
        Path::new(value).extension().is_some_and(|e| e.to_string_lossy().chars().all(|c| c.is_ascii_alphabetic()));
    let v = if over && (value.contains('/') || has_ext) {
        Path::new(value).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| value.to_string())
    } else {
        value.trim_matches('"').to_string()
    };
    v.chars().map(|c| if c.is_ascii_alphanumeric() || "-_.+=".contains(c) { c } else { '_' }).collect()
}

/// Expands the axes into items (cross product, or pairs with `zip`) with their folders.
pub fn items(axes: &[Axis], zip: bool, template: Option<&str>) -> Result<Vec<Item>, String> {
    if axes.is_empty() {
        return Err("a batch needs at least one --over or --sweep".into());
    }
    let combos: Vec<Vec<usize>> = if zip {
        let n = axes[0].values.len();
        if let Some(a) = axes.iter().find(|a| a.values.len() != n) {
            return Err(format!("--zip: {} has {} values but {} has {n}", a.label(), a.values.len(), axes[0].label()));
        }
        (0..n).map(|i| vec![i; axes.len()]).collect()
    } else {
        let mut combos = vec![vec![]];
        for a in axes {
            combos = combos
                .into_iter()
                .flat_map(|c: Vec<usize>| {
                    (0..a.values.len()).map(move |j| {
                        let mut c = c.clone();
                        c.push(j);
                        c
                    })
                })
                .collect();
        }
        combos
    };
    let template = template.map(str::to_string).unwrap_or_else(|| default_template(axes));
    let first_over = axes.iter().position(|a| a.over).unwrap_or(0);
    let mut out = Vec::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    for (index, combo) in combos.iter().enumerate() {
        let first = &axes[first_over].values[combo[first_over]];
        let mut dir = template
            .replace("{stem}", &path_part(first, true))
            .replace(
                "{name}",
                &path_part(&Path::new(first).file_name().map(|s| s.to_string_lossy()).unwrap_or_default(), false),
            )
            .replace("{index}", &index.to_string());
        for (a, &j) in axes.iter().zip(combo) {
            dir = dir.replace(&format!("{{{}}}", a.label()), &path_part(&a.values[j], a.over));
        }
        if let Some(bad) = dir.find('{').map(|i| &dir[i..]) {
            return Err(format!("--item-dir {template:?}: unknown placeholder in {bad:?}"));
        }
        let rel = Path::new(&dir);
        if dir.is_empty()
            || rel.is_absolute()
            || rel.components().any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            return Err(format!("--item-dir {template:?}: item {index} gets folder {dir:?}, not a relative folder"));
        }
        if let Some(other) = seen.insert(dir.clone(), index) {
            return Err(format!(
                "items {other} and {index} both map to folder {dir:?}; give --item-dir a template that tells them apart (e.g. add {{index}})"
            ));
        }
        let values = axes.iter().zip(combo).map(|(a, &j)| (a.label(), a.values[j].clone())).collect();
        out.push(Item { index, dir, values });
    }
    Ok(out)
}

/// Keeps the items of shard `i` of `n`: those whose index is congruent to `i` mod `n`.
pub fn shard(items: Vec<Item>, i: usize, n: usize) -> Vec<Item> {
    items.into_iter().filter(|it| it.index % n == i).collect()
}

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
    /// Nodes several items share are being computed first.
    fn shared_phase(&self, _nodes: usize) {}
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
    let mut uses: HashMap<Key, usize> = HashMap::new();
    for plan in plans.iter().flatten() {
        let keys: BTreeSet<Key> = (0..plan.status.len())
            .filter(|&i| plan.status[i] == NodeStatus::Computed)
            .filter_map(|i| plan.keys[i])
            .collect();
        for k in keys {
            *uses.entry(k).or_default() += 1;
        }
    }
    let mut claimed: BTreeSet<Key> = BTreeSet::new();
    let mut shared_jobs: Vec<(usize, Vec<String>)> = Vec::new();
    for (k, plan) in plans.iter().enumerate() {
        let Some(plan) = plan else { continue };
        let p = &pipelines[k];
        let shared = |i: usize| plan.keys[i].is_some_and(|key| uses.get(&key).copied().unwrap_or(0) > 1);
        let item_targets = targets(p);
        let mut names = Vec::new();
        for i in 0..plan.status.len() {
            if plan.status[i] != NodeStatus::Computed || !shared(i) {
                continue;
            }
            // Only the frontier is asked for (and so always stored): shared nodes that an item's
            // own nodes consume or that the item wants. Shared nodes inside the shared part run
            // too, as their inputs, and are stored only if the persistence policy says so.
            let frontier = item_targets.contains(&p.nodes[i].name)
                || p.consumers(i).into_iter().any(|c| plan.status[c] == NodeStatus::Computed && !shared(c));
            let key = plan.keys[i].expect("shared nodes are keyed");
            if frontier && claimed.insert(key) {
                names.push(p.nodes[i].name.clone());
            }
        }
        if !names.is_empty() {
            shared_jobs.push((k, names));
        }
    }
    // Shared keys stay pinned against pruning until every item that needs them has ended (the
    // folder may exceed the limit by them: they are what the batch cannot do without).
    let pinned: Mutex<HashMap<Key, usize>> =
        Mutex::new(uses.iter().filter(|(_, &n)| n > 1).map(|(k, &n)| (*k, n)).collect());
    let prune_lock = Mutex::new(());
    let prune = || {
        let _one_at_a_time = prune_lock.lock().expect("prune lock");
        let pins: BTreeSet<Key> = pinned.lock().expect("pinned lock").keys().copied().collect();
        // Pruning is housekeeping: a failure leaves the folder larger, the results are unchanged.
        let _ = cache.prune_sparing(options.cache_limit_bytes, &|k| pins.contains(k));
    };
    let mut shared_evaluations = 0;
    if !shared_jobs.is_empty() {
        options.observer.shared_phase(shared_jobs.iter().map(|j| j.1.len()).sum());
        for (k, names) in &shared_jobs {
            let run_options = RunOptions {
                targets: names.clone(),
                out_dir: options.out_dir.join(&items[*k].dir),
                // What the items will load must be stored even past the limit: evicting or
                // skipping it would make every item recompute it.
                cache: Some(cache.fork().with_add_limit(u64::MAX)),
                jobs: Some(threads),
                observer: &Silent,
            };
            // A failure here is the item's own failure, reported when it runs.
            if let Ok(o) = scheduler::run(&pipelines[*k], &run_options) {
                shared_evaluations += o.report.count(NodeStatus::Computed);
            }
        }
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
                    targets: targets(p),
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
                    let mine: BTreeSet<Key> = (0..plan.status.len())
                        .filter(|&i| plan.status[i] == NodeStatus::Computed)
                        .filter_map(|i| plan.keys[i])
                        .collect();
                    for key in mine {
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

/// The report rows as JSON values (item, index, values, status, ms, error, metrics).
pub fn json_rows(rows: &[ItemRow]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                let values: serde_json::Map<String, serde_json::Value> =
                    r.item.values.iter().map(|(k, v)| (k.clone(), v.clone().into())).collect();
                let metrics: serde_json::Map<String, serde_json::Value> =
                    r.metrics.iter().map(|(k, v)| (k.clone(), (*v).into())).collect();
                serde_json::json!({
                    "item": r.item.dir,
                    "index": r.item.index,
                    "values": values,
                    "status": r.status.word(),
                    "ms": r.ms,
                    "error": r.error,
                    "evaluations": r.evaluations,
                    "metrics": metrics,
                })
            })
            .collect(),
    )
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The report as CSV: item, index, values (`NODE.FIELD=value` joined by `;`), status, ms,
/// error, then one column per metrics field (`node.field`), sorted.
pub fn csv(rows: &[ItemRow]) -> String {
    let columns: BTreeSet<&str> = rows.iter().flat_map(|r| r.metrics.iter().map(|(k, _)| k.as_str())).collect();
    let mut s = String::from("item,index,values,status,ms,error");
    for c in &columns {
        s.push(',');
        s.push_str(&csv_field(c));
    }
    s.push('\n');
    for r in rows {
        let values: Vec<String> = r.item.values.iter().map(|(k, v)| format!("{k}={v}")).collect();
        s.push_str(&format!(
            "{},{},{},{},{:.3},{}",
            csv_field(&r.item.dir),
            r.item.index,
            csv_field(&values.join(";")),
            r.status.word(),
            r.ms,
            csv_field(r.error.as_deref().unwrap_or(""))
        ));
        let m: BTreeMap<&str, f64> = r.metrics.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        for c in &columns {
            s.push(',');
            if let Some(v) = m.get(c) {
                s.push_str(&v.to_string());
            }
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::Axis;

    /// Issue 25.6: a comma-separated `--over` list expands each glob and keeps plain names.
    #[test]
    fn an_over_list_mixing_a_glob_and_a_file_expands_each_item() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b_1k.hdr", "a_1k.hdr", "c_2k.hdr"] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        let d = dir.path().display();
        let axis = Axis::parse(&format!("env.path={d}/*_1k.hdr,{d}/c_2k.hdr"), true).unwrap();
        let names: Vec<String> =
            axis.values.iter().map(|v| v.rsplit('/').next().unwrap_or_default().to_string()).collect();
        assert_eq!(names, ["a_1k.hdr", "b_1k.hdr", "c_2k.hdr"]);
        let err = Axis::parse(&format!("env.path={d}/*_4k.hdr,{d}/c_2k.hdr"), true).unwrap_err();
        assert!(err.ends_with(&format!("no file matches \"{d}/*_4k.hdr\"")), "{err}");
        // --sweep values are never globs.
        assert_eq!(Axis::parse("e.stops=1,2", false).unwrap().values, ["1", "2"]);
    }
}
