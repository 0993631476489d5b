//! Planning and running a validated pipeline.
//!
//! 1. **Keys** (`plan`). Every ancestor of the targets gets its cache key, inputs first (loaders hash
//!    their file's content, in parallel).
//! 2. **Plan** (`plan`) (demand-driven, from the targets back): a needed node whose key is in the cache
//!    is `Cached` and its inputs are not needed for its sake; otherwise it is `Computed` and its
//!    inputs are needed. Everything else is `NotNeeded`. A node whose value the caller supplied
//!    (`Pipeline::provide`) is `Provided`: keyed by the value's content, never evaluated, and
//!    its inputs are not needed for its sake.
//! 3. **Load** (`load`) the cached values. An entry that turns out corrupt is reported, dropped, and the
//!    plan is made again without it, so that node and whatever it needs are computed.
//! 4. **Run** (`execute`) the `Computed` nodes on a rayon pool: a node starts as soon as its inputs are
//!    ready, so independent nodes run at once, and operators use the same pool for their own
//!    data parallelism. Each result is checked against its declared type and stored in the cache
//!    as soon as it exists.
//! 5. **Memory** (`state`, `admission`). Among the nodes ready to start, the one that lowers the
//!    memory the run holds the most goes first (the bytes of the inputs it is the last consumer
//!    of, minus its predicted output), and a node that makes a large value waits while starting it
//!    would raise the run's peak and other nodes are running. Every output port counts the
//!    consumers still to start (plus one if its node is a target). A consumer takes a clone of
//!    the value, and the last one takes the value itself, so the engine's reference is gone as
//!    soon as the last consumer has started and the value is freed when that consumer finishes
//!    with it, or earlier if it hands it back (`OpContext::release`); an operator that is the
//!    last consumer of an input can reuse its buffer (`Input::take`). Ports nothing consumes are
//!    dropped as soon as they are produced (after the cache has stored them).
//! 6. **Outputs** (`output`). File values (from `Save`) are written into the output folder atomically, and
//!    only when their bytes differ from what is already there. The folder is checked (created,
//!    a folder, writable) before anything is computed.

mod admission;
mod execute;
mod load;
mod output;
mod plan;
mod state;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::engine::cache::CacheStore;
use crate::engine::error::RunError;
use crate::engine::graph::Pipeline;
use crate::engine::value::Value;
use admission::Admission;
pub use output::check_output_dir;
pub use plan::{compute_keys, plan, Plan};
use state::{release_counts, Slot, State, Timing};

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

/// The steps of the module doc, in order.
fn run_in_pool(p: &Pipeline, options: &RunOptions) -> Result<RunOutcome, RunError> {
    let start = Instant::now();
    let obs = options.observer;
    let targets = plan::resolve_targets(p, &options.targets)?;
    let (keys, content) = plan::compute_keys_and_content(p, &targets)?;
    let cache = load::open_cache(options.cache.as_ref(), obs);
    let n = p.nodes.len();
    let timing: Vec<Mutex<Timing>> = (0..n).map(|_| Mutex::new(Timing::default())).collect();
    let kept = plan::kept_ports(p, &options.targets, &targets);
    let (status, loaded) = load::plan_and_load(p, &targets, &kept, &keys, cache.store, &timing, obs);
    let is_compute: Vec<bool> = status.iter().map(|s| *s == NodeStatus::Computed).collect();
    let compute: Vec<usize> = (0..n).filter(|&i| is_compute[i]).collect();
    obs.planned(compute.len(), status.iter().filter(|s| **s == NodeStatus::Cached).count());
    if (0..n).any(|i| status[i] != NodeStatus::NotNeeded && p.nodes[i].writes_file()) {
        check_output_dir(&options.out_dir)?;
    }

    let mut is_target = vec![false; n];
    for &i in &targets {
        is_target[i] = true;
    }
    let slots: Vec<Vec<Slot>> = release_counts(p, &is_compute, &kept)
        .into_iter()
        .map(|ports| {
            ports.into_iter().map(|c| Slot { value: Mutex::new(None), remaining: AtomicUsize::new(c) }).collect()
        })
        .collect();
    let state = State {
        p,
        options,
        cache: cache.store,
        cache_failed: AtomicBool::new(cache.read_only),
        limit_warned: AtomicBool::new(false),
        start,
        keys: &keys,
        content: &content,
        slots,
        timing,
        pending: (0..n)
            .map(|i| AtomicUsize::new(p.nodes[i].sources().filter(|s| is_compute[s.node]).count()))
            .collect(),
        consumers: (0..n).map(|i| p.consumers(i).into_iter().filter(|&c| is_compute[c]).collect()).collect(),
        abort: AtomicBool::new(false),
        first_error: Mutex::new(None),
        written: Mutex::new(Vec::new()),
        files: Mutex::new(Vec::new()),
        ready: admission_for(p),
        is_target,
        target_extras: Mutex::new(Vec::new()),
    };
    load::fill_slots(&state, &status, loaded)?;

    // The nodes with no input to wait for, chosen before any node runs: once the first ones run,
    // they start their consumers themselves, and a consumer whose count reached 0 meanwhile must
    // not be started a second time by this loop.
    let roots: Vec<usize> = compute.into_iter().filter(|&i| state.pending[i].load(Ordering::SeqCst) == 0).collect();
    rayon::scope(|scope| {
        for &i in &roots {
            execute::enqueue(&state, scope, i);
        }
    });
    finish(state, &status, &targets)
}

/// The ready queue, with each node's default output type and pixel count when known before
/// running (what its memory is predicted from, see `admission`).
fn admission_for(p: &Pipeline) -> Admission {
    Admission::new(p.nodes.iter().map(output_shape).collect())
}

/// A node's default output type and pixel count, when its size is known before running.
fn output_shape(node: &crate::engine::graph::Node) -> Option<(crate::engine::value::ValueType, u64)> {
    Some((node.output_type()?, node.size.map(|(w, h)| w.saturating_mul(h))?))
}

/// The outcome of a run that has ended: its report and the targets' values.
fn finish(state: State, status: &[NodeStatus], targets: &[usize]) -> Result<RunOutcome, RunError> {
    if let Some(e) = state.first_error.into_inner().expect("error lock") {
        return Err(e);
    }
    let p = state.p;
    let nodes = (0..p.nodes.len())
        .map(|i| state::node_report(p, i, status[i], *state.timing[i].lock().expect("timing lock"), state.keys))
        .collect();
    let mut values = BTreeMap::new();
    for &t in targets {
        for (port, slot) in state.slots[t].iter().enumerate() {
            if let Some(v) = slot.value.lock().expect("slot lock").take() {
                values.insert(p.nodes[t].port_label(port), v);
            }
        }
    }
    for (t, port, v) in state.target_extras.into_inner().expect("extras lock") {
        values.insert(format!("{}.{port}", p.nodes[t].name), v);
    }
    let mut written = state.written.into_inner().expect("written lock");
    written.sort();
    let mut files = state.files.into_inner().expect("files lock");
    files.sort();
    let report = RunReport { total_ms: state.start.elapsed().as_secs_f64() * 1e3, nodes, written, files };
    Ok(RunOutcome { report, values })
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::sync::{Arc, Mutex, Weak};

    use super::*;
    use crate::engine::fields::Input;
    use crate::engine::op::{OpContext, OpError, OpSpec, OutputType, Outputs};
    use crate::engine::registry::Registry;
    use crate::values::ty::IMAGE_T;
    use crate::values::Image;

    crate::params! {
        struct SrcParams {
            /// width of the image made
            width: usize = 1,
        }
    }
    crate::params! {
        struct PassParams {
            /// passed on
            #[input(&[IMAGE_T])]
            x: Input<Image>,
            /// read and dropped
            #[input(&[IMAGE_T])]
            y: Option<Input<Image>>,
        }
    }

    /// Weak references to what `Src` nodes made, and per `Pass` node whether each input's
    /// buffer was its own (the run had let go of it), by node name. Tests use distinct names.
    static MADE: Mutex<Vec<(String, Weak<Image>)>> = Mutex::new(Vec::new());
    static OWNED: Mutex<Vec<(String, [bool; 2])>> = Mutex::new(Vec::new());

    fn src(ctx: &mut OpContext, p: SrcParams) -> Result<Value, OpError> {
        let image = Arc::new(Image::new(p.width, 1, 3));
        MADE.lock().unwrap().push((ctx.node.to_string(), Arc::downgrade(&image)));
        Ok(Value::from_arc(image))
    }

    fn pass(ctx: &mut OpContext, p: PassParams) -> Result<Value, OpError> {
        // `take` moves the buffer out when nothing else holds the value, and copies it otherwise.
        let own = |i: Input<Image>| {
            let buffer = i.data.as_ptr();
            i.take().data.as_ptr() == buffer
        };
        let owned = [own(p.x), p.y.is_none_or(own)];
        OWNED.lock().unwrap().push((ctx.node.to_string(), owned));
        Ok(Value::new(Image::new(1, 1, 3)))
    }

    /// Per `Release` node: whether its input was gone right after it handed it back (true) and
    /// whether its copy of a shared input was (false: another consumer still needs it).
    static RELEASED: Mutex<Vec<(String, bool)>> = Mutex::new(Vec::new());

    fn release(ctx: &mut OpContext, p: PassParams) -> Result<Value, OpError> {
        let weak = Arc::downgrade(&p.x.arc());
        ctx.release(p.x.into_value());
        RELEASED.lock().unwrap().push((ctx.node.to_string(), weak.upgrade().is_none()));
        Ok(Value::new(Image::new(1, 1, 3)))
    }

    /// Two ports: `image` (width 8) and `small` (width 1).
    fn two(_: &mut OpContext, _: SrcParams) -> Result<Outputs, OpError> {
        Ok(Outputs::new().with("image", Value::new(Image::new(8, 1, 3))).with("small", Value::new(Image::new(1, 1, 3))))
    }

    fn pipeline(text: &str) -> Pipeline {
        let mut r = Registry::empty();
        crate::values::register_all(&mut r);
        r.register(
            OpSpec::new("Src", "test", 1, "an image").output("image", OutputType::Fixed(IMAGE_T), "it").eval(src),
        )
        .unwrap();
        r.register(
            OpSpec::new("Pass", "test", 1, "reads x and y")
                .output("image", OutputType::Fixed(IMAGE_T), "it")
                .eval(pass),
        )
        .unwrap();
        r.register(
            OpSpec::new("Two", "test", 1, "two images")
                .output("image", OutputType::Fixed(IMAGE_T), "the first")
                .output("small", OutputType::Fixed(IMAGE_T), "the second")
                .eval(two),
        )
        .unwrap();
        r.register(
            OpSpec::new("Release", "test", 1, "hands x back first")
                .output("image", OutputType::Fixed(IMAGE_T), "it")
                .eval(release),
        )
        .unwrap();
        Pipeline::parse(text, "t.ron", Path::new("."), &r, &[]).expect("validates")
    }

    /// Start and finish events in order.
    #[derive(Default)]
    struct Events(Mutex<Vec<String>>);
    impl Observer for Events {
        fn node_started(&self, name: &str) {
            self.0.lock().unwrap().push(format!("start {name}"));
        }
        fn node_finished(&self, r: &NodeReport) {
            self.0.lock().unwrap().push(format!("end {}", r.name));
        }
    }

    fn run_one_thread(p: &Pipeline, targets: &[&str], obs: &Events) -> RunOutcome {
        let out = tempfile::tempdir().unwrap();
        let options = RunOptions {
            targets: targets.iter().map(|t| t.to_string()).collect(),
            out_dir: out.path().to_path_buf(),
            cache: None,
            jobs: Some(1),
            observer: obs,
        };
        run(p, &options).expect("runs")
    }

    /// Each port waits for one release per input edge of a computed node (a node reading it
    /// twice counts twice) plus one if its node is a target; ports of nodes not computed wait
    /// for nothing of theirs.
    #[test]
    fn release_counts_are_input_edges_plus_targets() {
        let p = pipeline(
            r#"(nodes: { "a": Src(), "b": Pass(x: "a", y: "a"), "c": Pass(x: "a"), "d": Pass(x: "c"), "e": Src() })"#,
        );
        let idx = |name: &str| p.nodes.iter().position(|n| n.name == name).unwrap();
        let mut is_compute = vec![true; p.nodes.len()];
        is_compute[idx("d")] = false; // as if served from the cache
        let kept = plan::kept_ports(&p, &["b".into(), "d".into()], &[idx("b"), idx("d")]);
        let counts = release_counts(&p, &is_compute, &kept);
        assert_eq!(counts[idx("a")], [3]);
        assert_eq!(counts[idx("b")], [1]);
        assert_eq!(counts[idx("c")], [0], "its only consumer is not computed");
        assert_eq!(counts[idx("d")], [1]);
        assert_eq!(counts[idx("e")], [0]);
    }

    /// A `node.port` target keeps only that port for the caller: the node's other port goes to its
    /// last consumer, which gets the buffer itself; naming the node keeps every port, and the
    /// consumer gets a copy.
    #[test]
    fn a_port_target_keeps_only_its_port() {
        let p = pipeline(
            r#"(nodes: { "two_a": Two(), "pass_a": Pass(x: "two_a"), "two_b": Two(), "pass_b": Pass(x: "two_b") })"#,
        );
        let obs = Events::default();
        let out = run_one_thread(&p, &["two_a.small", "pass_a"], &obs);
        assert!(out.values.contains_key("two_a.small") && !out.values.contains_key("two_a"), "{:?}", out.values.keys());
        let out = run_one_thread(&p, &["two_b", "pass_b"], &obs);
        assert!(out.values.contains_key("two_b") && out.values.contains_key("two_b.small"));
        let owned = OWNED.lock().unwrap();
        let of = |name: &str| owned.iter().find(|(n, _)| n == name).map(|(_, o)| o[0]);
        assert_eq!(of("pass_a"), Some(true), "the unkept port's buffer moves to its consumer");
        assert_eq!(of("pass_b"), Some(false), "a kept port is copied for its consumer");
    }

    /// A node starts only after every input has finished; of two nodes made ready at once, the
    /// one that is the last consumer of the larger value starts first, although the other comes
    /// first in the file; the last consumer of a value gets the buffer itself, an earlier one a
    /// shared copy; nothing but the targets' values outlives the run.
    #[test]
    fn order_and_release_on_one_thread() {
        let p = pipeline(
            r#"(nodes: {
                "o_big": Src(width: 4096), "o_small": Src(width: 1), "o_r": Src(width: 2),
                "o_c1": Pass(x: "o_r", y: "o_small"),
                "o_c2": Pass(x: "o_r", y: "o_big"),
            })"#,
        );
        let obs = Events::default();
        let outcome = run_one_thread(&p, &["o_c1", "o_c2"], &obs);
        let events = obs.0.into_inner().unwrap();
        let at = |e: &str| events.iter().position(|x| x == e).unwrap_or_else(|| panic!("{e} in {events:?}"));
        for (input, node) in [("o_r", "o_c1"), ("o_small", "o_c1"), ("o_r", "o_c2"), ("o_big", "o_c2")] {
            assert!(at(&format!("end {input}")) < at(&format!("start {node}")), "{events:?}");
        }
        assert!(at("start o_c2") < at("start o_c1"), "the one freeing o_big first: {events:?}");
        let owned: Vec<(String, [bool; 2])> =
            OWNED.lock().unwrap().iter().filter(|(n, _)| n.starts_with("o_")).cloned().collect();
        assert_eq!(owned, [("o_c2".to_string(), [false, true]), ("o_c1".to_string(), [true, true])]);
        let made = MADE.lock().unwrap();
        assert!(made.iter().filter(|(n, _)| n.starts_with("o_")).all(|(_, w)| w.upgrade().is_none()));
        assert_eq!(outcome.values.keys().collect::<Vec<_>>(), ["o_c1", "o_c2"]);
    }

    /// A value its last consumer hands back early (`OpContext::release`) is freed then, before
    /// that node finishes; an earlier consumer's copy handed back frees nothing.
    #[test]
    fn a_value_handed_back_by_its_last_consumer_is_freed_then() {
        let p = pipeline(
            r#"(nodes: { "r_a": Src(width: 64), "r_b": Src(width: 64), "r_1": Release(x: "r_a"),
                "r_2": Release(x: "r_b"), "r_3": Pass(x: "r_b") })"#,
        );
        let obs = Events::default();
        run_one_thread(&p, &["r_1", "r_2", "r_3"], &obs);
        let released: Vec<(String, bool)> =
            RELEASED.lock().unwrap().iter().filter(|(n, _)| n.starts_with("r_")).cloned().collect();
        assert_eq!(released, [("r_1".to_string(), true), ("r_2".to_string(), false)]);
    }

    /// A node served from the cache needs none of its inputs: they are not computed.
    #[test]
    fn a_cached_node_needs_no_inputs() {
        let p = pipeline(r#"(nodes: { "k_a": Src(), "k_b": Pass(x: "k_a"), "k_c": Pass(x: "k_b") })"#);
        let dir = tempfile::tempdir().unwrap();
        let cache = CacheStore::new(dir.path().to_path_buf(), u64::MAX);
        let obs = Events::default();
        let options = RunOptions {
            targets: vec!["k_b".into()],
            out_dir: dir.path().join("out"),
            cache: Some(cache.clone()),
            jobs: Some(1),
            observer: &obs,
        };
        run(&p, &options).expect("runs");
        let planned = plan(&p, &["k_c".into()], Some(&cache)).unwrap();
        let status: Vec<NodeStatus> = planned.status;
        assert_eq!(status, [NodeStatus::NotNeeded, NodeStatus::Cached, NodeStatus::Computed]);
    }
}
