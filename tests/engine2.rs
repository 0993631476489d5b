//! Engine 2 through the library (and, where stated, the binary): output ports, list and optional
//! inputs, open value types with their own codecs, positions in validation errors, the memory
//! contract (buffers moved to the last consumer, values freed after it), very long chains, the
//! output-folder and cache-folder checks, the type contract, RGBA EXR and the seed estimator's
//! scale under a distribution of another resolution.
//!
//! The operators and value types below exist only in this file: they are registered on
//! `hdrflow::builtin_registry()` exactly as a library user would register theirs.

mod common;

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use hdrflow::engine::cache::codec::{Reader, Writer};
use hdrflow::engine::cache::CacheStore;
use hdrflow::engine::error::{PipelineErrors, RunError};
use hdrflow::engine::fields::Input;
use hdrflow::engine::op::{OpContext, OpError, OpSpec, OutputType, Outputs};
use hdrflow::engine::scheduler::{self, NodeStatus, RunOptions, RunOutcome, Silent};
use hdrflow::engine::value::{TypeSpec, Value, ValueData, ValueType};
use hdrflow::values::ty::{ANY_IMAGE, IMAGE_T, SCALAR_T};
use hdrflow::values::Image;
use hdrflow::{Pipeline, Registry};

use common::{files_under, ron_path, Sandbox, RUN_TIMEOUT};

// ---------------------------------------------------------------------------------------------
// A test-only value type: a pair of numbers, with its own cache codec.
// ---------------------------------------------------------------------------------------------

/// `(a, b)`; what `MinMax`, `Sum`, `Offset` and `PairConst` pass around.
#[derive(Clone, Debug, PartialEq)]
struct Pair(f64, f64);

/// How many times the pair codec decoded a payload (the cache served a pair).
static PAIR_DECODES: AtomicUsize = AtomicUsize::new(0);

static PAIR: TypeSpec = TypeSpec { name: "pair", doc: "a test-only pair of numbers", decode: decode_pair };
const PAIR_T: ValueType = ValueType(&PAIR);

/// The payload starts with a tag, so a pair can only come back through this codec.
const PAIR_TAG: &[u8; 4] = b"PAIR";

impl ValueData for Pair {
    fn value_type(&self) -> ValueType {
        PAIR_T
    }
    fn approx_bytes(&self) -> usize {
        16
    }
    fn encode(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(PAIR_TAG);
        let mut w = Writer(out);
        w.f64(self.0);
        w.f64(self.1);
    }
}

fn decode_pair(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    if r.take(4)? != PAIR_TAG {
        return Err("not a pair payload".into());
    }
    let (a, b) = (r.f64()?, r.f64()?);
    r.finish()?;
    PAIR_DECODES.fetch_add(1, Ordering::SeqCst);
    Ok(Value::new(Pair(a, b)))
}

// ---------------------------------------------------------------------------------------------
// A test-only value type whose drop is recorded (the memory contract).
// ---------------------------------------------------------------------------------------------

/// Tags of the `Tracked` values dropped so far (a tag is the name of the node that made it).
static DROPPED: Mutex<Vec<String>> = Mutex::new(Vec::new());

#[derive(Debug)]
struct Tracked {
    tag: String,
}

impl Drop for Tracked {
    fn drop(&mut self) {
        DROPPED.lock().unwrap().push(self.tag.clone());
    }
}

static TRACKED: TypeSpec = TypeSpec {
    name: "tracked",
    doc: "a test-only value whose drop is recorded",
    decode: |_| Err("tracked values are not cached".into()),
};
const TRACKED_T: ValueType = ValueType(&TRACKED);

impl ValueData for Tracked {
    fn value_type(&self) -> ValueType {
        TRACKED_T
    }
    fn approx_bytes(&self) -> usize {
        self.tag.len()
    }
    fn encode(&self, out: &mut Vec<u8>) {
        Writer(out).str(&self.tag);
    }
}

fn dropped_with_prefix(prefix: &str) -> Vec<String> {
    DROPPED.lock().unwrap().iter().filter(|t| t.starts_with(prefix)).cloned().collect()
}

// ---------------------------------------------------------------------------------------------
// What the test operators record while they run, by node name (node names are unique per test).
// ---------------------------------------------------------------------------------------------

/// Buffer addresses (`data.as_ptr()`) recorded by `Source` and `Take`.
static PTRS: Mutex<BTreeMap<String, usize>> = Mutex::new(BTreeMap::new());
/// What `Peek` saw: the sum of its input's samples.
static PEEKED: Mutex<BTreeMap<String, f64>> = Mutex::new(BTreeMap::new());
/// The `Tracked` tags already dropped when a `TrackedSink` ran.
static SEEN_DROPPED: Mutex<BTreeMap<String, Vec<String>>> = Mutex::new(BTreeMap::new());

/// A rendezvous: `meet(name)` returns once two nodes have called it with that name (or after a
/// timeout, returning false), so both hold their inputs at the same time.
static MEETINGS: Mutex<Option<HashMap<String, usize>>> = Mutex::new(None);
static MEETING_CV: Condvar = Condvar::new();

fn meet(name: &str) -> bool {
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut guard = MEETINGS.lock().unwrap();
    *guard.get_or_insert_with(HashMap::new).entry(name.to_string()).or_insert(0) += 1;
    MEETING_CV.notify_all();
    loop {
        if guard.as_ref().unwrap()[name] >= 2 {
            return true;
        }
        let now = Instant::now();
        if now >= deadline {
            return false;
        }
        guard = MEETING_CV.wait_timeout(guard, deadline - now).unwrap().0;
    }
}

/// Waits (at most 20 s) until `PTRS` has an entry for `node`.
fn wait_for_ptr(node: &str) -> bool {
    let deadline = Instant::now() + Duration::from_secs(20);
    while Instant::now() < deadline {
        if PTRS.lock().unwrap().contains_key(node) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    false
}

// ---------------------------------------------------------------------------------------------
// Test-only operators.
// ---------------------------------------------------------------------------------------------

hdrflow::params! {
    struct ImageIn {
        /// the image
        #[input(ANY_IMAGE)]
        image: Input<Image>,
    }
}

/// `MinMax(image) -> min, max`: two ports, each `(value, flat index of its first occurrence)`.
fn minmax_spec() -> OpSpec {
    OpSpec::new("MinMax", "test", 1, "Smallest and largest sample of an image, with their flat indices")
        .output("min", OutputType::Fixed(PAIR_T), "(smallest sample, its index)")
        .output("max", OutputType::Fixed(PAIR_T), "(largest sample, its index)")
        .eval(minmax)
}

fn minmax(_: &mut OpContext, p: ImageIn) -> Result<Outputs, OpError> {
    let img = &*p.image;
    let (mut lo, mut hi) = ((f32::INFINITY, 0usize), (f32::NEG_INFINITY, 0usize));
    for (i, &v) in img.data.iter().enumerate() {
        if v < lo.0 {
            lo = (v, i);
        }
        if v > hi.0 {
            hi = (v, i);
        }
    }
    Ok(Outputs::new()
        .with("min", Value::new(Pair(lo.0 as f64, lo.1 as f64)))
        .with("max", Value::new(Pair(hi.0 as f64, hi.1 as f64))))
}

hdrflow::params! {
    struct SumParams {
        /// the pairs, in order
        #[input(&[PAIR_T])]
        #[range(1, 4)]
        values: Vec<Input<Pair>>,
    }
}

/// `Sum(values: [1..4 pairs])`: (sum of the first components, sum of (position + 1) * second
/// component): the second component shows the order the values arrived in.
fn sum_spec() -> OpSpec {
    OpSpec::new("Sum", "test", 1, "Sum of pairs, the second components weighted by position")
        .output("sum", OutputType::Fixed(PAIR_T), "the sum")
        .eval(sum)
}

fn sum(_: &mut OpContext, params: SumParams) -> Result<Value, OpError> {
    let mut out = Pair(0.0, 0.0);
    for (k, p) in params.values.iter().enumerate() {
        out.0 += p.0;
        out.1 += (k + 1) as f64 * p.1;
    }
    Ok(Value::new(out))
}

hdrflow::params! {
    struct OffsetParams {
        /// the pair
        #[input(&[PAIR_T])]
        value: Input<Pair>,
        /// what to add (nothing when not wired)
        #[input(&[PAIR_T])]
        by: Option<Input<Pair>>,
    }
}

/// `Offset(value, by: optional)`: value + by, or value itself when `by` is not wired.
fn offset_spec() -> OpSpec {
    OpSpec::new("Offset", "test", 1, "A pair plus an optional pair")
        .output("value", OutputType::Fixed(PAIR_T), "the sum")
        .eval(offset)
}

fn offset(_: &mut OpContext, p: OffsetParams) -> Result<Value, OpError> {
    let v = (*p.value).clone();
    Ok(Value::new(match p.by.as_deref() {
        Some(b) => Pair(v.0 + b.0, v.1 + b.1),
        None => v,
    }))
}

hdrflow::params! {
    struct PairConstParams {
        /// first component
        a: f64,
        /// second component
        b: f64,
    }
}

fn pair_const_spec() -> OpSpec {
    OpSpec::new("PairConst", "test", 1, "A constant pair")
        .output("pair", OutputType::Fixed(PAIR_T), "(a, b)")
        .eval(|_, p: PairConstParams| Ok(Value::new(Pair(p.a, p.b))))
}

/// `Split(image)`: no declared port, one open port per channel name (`"split.G"`).
fn split_spec() -> OpSpec {
    OpSpec::new("Split", "test", 1, "The channels of an image, as open ports named like the channels")
        .open_ports(SCALAR_T, "one channel, by name")
        .eval(split)
}

fn split(ctx: &mut OpContext, p: RgbIn) -> Result<Outputs, OpError> {
    let img = &*p.image;
    let mut out = Outputs::new();
    for name in ctx.wanted_ports {
        let i = img.channel_index(name).ok_or_else(|| OpError::Invalid(format!("no channel {name:?}")))?;
        out = out.with(name.clone(), Value::new(img.channel(i)));
    }
    Ok(out)
}

/// `Liar(lie: WrongType | MissingPort)`: breaks its declaration (two pair ports).
fn liar_spec() -> OpSpec {
    OpSpec::new("Liar", "test", 1, "Declares two pairs, returns something else")
        .output("a", OutputType::Fixed(PAIR_T), "a pair, it says")
        .output("b", OutputType::Fixed(PAIR_T), "another pair, it says")
        .eval(liar)
}

hdrflow::choice! { enum Lie { WrongType, MissingPort } }

hdrflow::params! {
    struct LiarParams {
        /// how to break the declaration
        lie: Lie,
    }
}

fn liar(_: &mut OpContext, p: LiarParams) -> Result<Outputs, OpError> {
    Ok(match p.lie {
        Lie::WrongType => {
            Outputs::new().with("a", Value::new(Image::new(1, 1, 3))).with("b", Value::new(Pair(1.0, 2.0)))
        }
        Lie::MissingPort => Outputs::new().with("a", Value::new(Pair(1.0, 2.0))),
    })
}

hdrflow::params! {
    struct SourceParams {
        /// width and height
        #[range(1, 4096)]
        size: usize = 16,
    }
}

/// `Source(size)`: a grey image of ones; records its buffer's address under its node name.
fn source_spec() -> OpSpec {
    OpSpec::new("Source", "test", 1, "An RGB image of ones whose buffer address is recorded")
        .output("image", OutputType::Fixed(IMAGE_T), "the image")
        .eval(source)
}

fn source(ctx: &mut OpContext, p: SourceParams) -> Result<Value, OpError> {
    let img = Image::from_vec(p.size, p.size, 3, vec![1.0; p.size * p.size * 3]);
    PTRS.lock().unwrap().insert(ctx.node.to_string(), img.data.as_ptr() as usize);
    Ok(Value::new(img))
}

hdrflow::params! {
    struct RgbIn {
        /// the image
        #[input(&[IMAGE_T])]
        image: Input<Image>,
    }
}

hdrflow::params! {
    struct MeetParams {
        /// the image
        #[input(&[IMAGE_T])]
        image: Input<Image>,
        /// when not empty: first wait until another node has reached the rendezvous of this name
        meet: String = String::new(),
    }
}

/// `Take(image, meet)`: takes its input by value (`OpContext::take`), records the buffer's
/// address, then doubles every sample in place.
fn take_spec() -> OpSpec {
    OpSpec::new("Take", "test", 1, "Take the input's buffer, record its address, double it")
        .output("image", OutputType::Fixed(IMAGE_T), "the doubled image")
        .eval(take)
}

fn take(ctx: &mut OpContext, p: MeetParams) -> Result<Value, OpError> {
    if !p.meet.is_empty() && !meet(&p.meet) {
        return Err(OpError::Invalid(format!("nobody came to the rendezvous {:?}", p.meet)));
    }
    let mut img = p.image.take();
    img.data.iter_mut().for_each(|v| *v *= 2.0);
    PTRS.lock().unwrap().insert(ctx.node.to_string(), img.data.as_ptr() as usize);
    Ok(Value::new(img))
}

hdrflow::params! {
    struct PeekParams {
        /// the image
        #[input(&[IMAGE_T])]
        image: Input<Image>,
        /// when not empty: first wait until another node has reached the rendezvous of this name
        meet: String = String::new(),
        /// when not empty: then wait until this node has recorded its buffer (it has modified it)
        after: String = String::new(),
    }
}

/// `Peek(image, meet, after)`: reads its input (by reference) and records the sum of its samples.
fn peek_spec() -> OpSpec {
    OpSpec::new("Peek", "test", 1, "Record the sum of the input's samples")
        .output("image", OutputType::Fixed(IMAGE_T), "a 1x1 image of the sum")
        .eval(peek)
}

fn peek(ctx: &mut OpContext, p: PeekParams) -> Result<Value, OpError> {
    if !p.meet.is_empty() && !meet(&p.meet) {
        return Err(OpError::Invalid(format!("nobody came to the rendezvous {:?}", p.meet)));
    }
    if !p.after.is_empty() && !wait_for_ptr(&p.after) {
        return Err(OpError::Invalid(format!("{:?} never recorded its buffer", p.after)));
    }
    let img = &*p.image;
    let s: f64 = img.data.iter().map(|&v| v as f64).sum();
    PEEKED.lock().unwrap().insert(ctx.node.to_string(), s);
    Ok(Value::new(Image::from_vec(1, 1, 3, vec![s as f32; 3])))
}

hdrflow::params! {
    struct NoFields {}
}

hdrflow::params! {
    struct TrackedIn {
        /// the input
        #[input(&[TRACKED_T])]
        input: Input<Tracked>,
    }
}

/// `TrackedMake()`, `TrackedStep(input)`, `TrackedSink(input)`: each makes a new `Tracked`
/// tagged with its node name; the sink records which tags were dropped when it ran.
fn tracked_specs() -> [OpSpec; 3] {
    [
        OpSpec::new("TrackedMake", "test", 1, "A tracked value")
            .output("value", OutputType::Fixed(TRACKED_T), "it")
            .eval(|ctx, _: NoFields| Ok(Value::new(Tracked { tag: ctx.node.to_string() }))),
        OpSpec::new("TrackedStep", "test", 1, "A new tracked value from one")
            .output("value", OutputType::Fixed(TRACKED_T), "a new one")
            .eval(|ctx, p: TrackedIn| {
                let _: &Tracked = &p.input;
                Ok(Value::new(Tracked { tag: ctx.node.to_string() }))
            }),
        OpSpec::new("TrackedSink", "test", 1, "Records the drops so far")
            .output("value", OutputType::Fixed(TRACKED_T), "a new one")
            .eval(|ctx, p: TrackedIn| {
                let input: &Tracked = &p.input;
                let prefix: String = input.tag.chars().take_while(|c| *c != '_').collect();
                SEEN_DROPPED.lock().unwrap().insert(ctx.node.to_string(), dropped_with_prefix(&prefix));
                Ok(Value::new(Tracked { tag: ctx.node.to_string() }))
            }),
    ]
}

hdrflow::params! {
    struct BlendParams {
        /// the image
        #[input(&[IMAGE_T])]
        image: Input<Image>,
        /// added when wired
        #[input(&[IMAGE_T])]
        extra: Option<Input<Image>>,
    }
}

/// `Blend(image, extra: optional image)`: the image (plus `extra` when wired).
fn blend_spec() -> OpSpec {
    OpSpec::new("Blend", "test", 1, "An image plus an optional one")
        .output("image", OutputType::Fixed(IMAGE_T), "the sum")
        .eval(|_, p: BlendParams| {
            let mut img = p.image.take();
            if let Some(e) = p.extra.as_deref() {
                img.data.iter_mut().zip(&e.data).for_each(|(a, b)| *a += b);
            }
            Ok(Value::new(img))
        })
}

/// How many times each `Tick` node was evaluated.
static TICKS: Mutex<BTreeMap<String, usize>> = Mutex::new(BTreeMap::new());

hdrflow::params! {
    struct TickParams {
        /// passed on
        #[input(&[PAIR_T])]
        input: Option<Input<Pair>>,
    }
}

/// `Tick(input: optional pair)`: counts its evaluations; passes its input on (or (0, 0)).
fn tick_spec() -> OpSpec {
    OpSpec::new("Tick", "test", 1, "Count evaluations")
        .output("value", OutputType::Fixed(PAIR_T), "the input, or (0, 0)")
        .eval(|ctx, p: TickParams| {
            *TICKS.lock().unwrap().entry(ctx.node.to_string()).or_insert(0) += 1;
            Ok(Value::new(p.input.as_deref().cloned().unwrap_or(Pair(0.0, 0.0))))
        })
}

/// The built-in registry plus this file's value types and operators.
fn registry() -> Registry {
    let mut r = hdrflow::builtin_registry();
    r.register_type(&PAIR).register_type(&TRACKED);
    for spec in [
        minmax_spec(),
        sum_spec(),
        offset_spec(),
        pair_const_spec(),
        split_spec(),
        liar_spec(),
        source_spec(),
        take_spec(),
        peek_spec(),
        blend_spec(),
        tick_spec(),
    ] {
        r.register(spec).unwrap();
    }
    for spec in tracked_specs() {
        r.register(spec).unwrap();
    }
    r
}

// ---------------------------------------------------------------------------------------------
// Helpers.
// ---------------------------------------------------------------------------------------------

fn parse(text: &str, registry: &Registry) -> Result<Pipeline, PipelineErrors> {
    Pipeline::parse(text, "test.ron", Path::new("."), registry, &[])
}

#[track_caller]
fn parse_ok(text: &str, registry: &Registry) -> Pipeline {
    parse(text, registry).unwrap_or_else(|e| panic!("the pipeline does not validate:\n{e}\n{text}"))
}

/// Every message of a failed validation, one `file:line:col: node "x": message` per entry.
#[track_caller]
fn parse_errors(text: &str, registry: &Registry) -> Vec<String> {
    match parse(text, registry) {
        Ok(_) => panic!("the pipeline validated, but should not have:\n{text}"),
        Err(e) => e.0.iter().map(|e| e.to_string()).collect(),
    }
}

fn run(
    p: &Pipeline,
    targets: &[&str],
    out_dir: &Path,
    cache: Option<CacheStore>,
    jobs: usize,
) -> Result<RunOutcome, RunError> {
    let options = RunOptions {
        targets: targets.iter().map(|t| t.to_string()).collect(),
        out_dir: out_dir.to_path_buf(),
        cache,
        jobs: Some(jobs),
        observer: &Silent,
    };
    scheduler::run(p, &options)
}

#[track_caller]
fn run_ok(p: &Pipeline, targets: &[&str], out_dir: &Path, cache: Option<CacheStore>, jobs: usize) -> RunOutcome {
    run(p, targets, out_dir, cache, jobs).unwrap_or_else(|e| panic!("the run failed: {e}"))
}

#[track_caller]
fn pair(outcome: &RunOutcome, name: &str) -> Pair {
    let v = outcome.values.get(name).unwrap_or_else(|| {
        panic!("no value {name:?} in the outcome (values: {:?})", outcome.values.keys().collect::<Vec<_>>())
    });
    v.get::<Pair>().unwrap_or_else(|| panic!("{name} is a {}, not a pair", v.value_type())).clone()
}

#[track_caller]
fn image(outcome: &RunOutcome, name: &str) -> Image {
    let v = outcome.values.get(name).unwrap_or_else(|| panic!("no value {name:?} in the outcome"));
    v.get::<Image>().unwrap_or_else(|| panic!("{name} is a {}, not an image", v.value_type())).clone()
}

#[track_caller]
fn key_of(outcome: &RunOutcome, node: &str) -> String {
    let n = outcome.report.nodes.iter().find(|n| n.name == node).unwrap_or_else(|| panic!("no node {node:?}"));
    assert!(!n.key.is_empty(), "node {node:?} has no key");
    n.key.clone()
}

fn cache_in(dir: &Path) -> CacheStore {
    CacheStore::new(dir, 1 << 30)
}

// ---------------------------------------------------------------------------------------------
// 1. Ports, lists, optional inputs, open ports and a custom value type, end to end and cached.
// ---------------------------------------------------------------------------------------------

/// `Sum`'s list, in an order given by the caller; everything else is fixed.
fn ports_pipeline(values: &str) -> String {
    format!(
        r#"(
    nodes: {{
        "c":     Constant(width: 4, height: 3, color: (0.25, 0.5, 2.0)),
        "e":     Exposure(image: "c", stops: 1.0),
        "mm":    MinMax(image: "c"),
        "mm2":   MinMax(image: "e"),
        "split": Split(image: "c"),
        "mmg":   MinMax(image: "split.G"),
        "sum":   Sum(values: {values}),
        "zero":  PairConst(a: 0.0, b: 0.0),
        "off":   Offset(value: "sum"),
        "off0":  Offset(value: "sum", by: "zero"),
        "off1":  Offset(value: "sum", by: "mm.max"),
    }},
)"#
    )
}

const PORT_TARGETS: &[&str] = &["mm", "mmg", "split", "sum", "off", "off0", "off1"];

#[test]
fn ports_lists_and_optional_inputs_run_end_to_end_and_are_served_from_the_cache() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let cache_dir = tmp.path().join("cache");

    let text = ports_pipeline(r#"["mm.min", "mm2.max", "mm.max"]"#);
    let p = parse_ok(&text, &registry);
    let first = run_ok(&p, PORT_TARGETS, &out, Some(cache_in(&cache_dir)), 2);

    // Every port of every target, under `node` (the default port) and `node.port`.
    let names: Vec<&str> = first.values.keys().map(String::as_str).collect();
    // `Split` declares no port, so it has no default one: its open port is `split.G`, never `split`.
    assert_eq!(names, ["mm", "mm.max", "mmg", "mmg.max", "off", "off0", "off1", "split.G", "sum"]);
    assert_eq!(image(&first, "split.G").data, [0.5; 12]);
    // c = (0.25, 0.5, 2.0) per pixel; e = 2c.
    assert_eq!(pair(&first, "mm"), Pair(0.25, 0.0), "MinMax's default port is `min`");
    assert_eq!(pair(&first, "mm.max"), Pair(2.0, 2.0));
    assert_eq!(pair(&first, "mmg"), Pair(0.5, 0.0), "the open port split.G is the G channel");
    assert_eq!(pair(&first, "mmg.max"), Pair(0.5, 0.0));
    // Sum of [mm.min, mm2.max, mm.max] = [(0.25, 0), (4, 2), (2, 2)]: 6.25, 1*0 + 2*2 + 3*2.
    assert_eq!(pair(&first, "sum"), Pair(6.25, 10.0), "the list arrives in the written order");
    assert_eq!(pair(&first, "off"), Pair(6.25, 10.0), "unwired optional input");
    assert_eq!(pair(&first, "off0"), Pair(6.25, 10.0), "optional input wired to (0, 0)");
    assert_eq!(pair(&first, "off1"), Pair(8.25, 12.0), "optional input wired to mm.max");
    let computed = first.report.count(NodeStatus::Computed);
    assert_eq!(computed, 11, "every node is needed by the targets: {:#?}", first.report.nodes);

    // An unwired optional input and one wired to a value equal to "nothing added" are different
    // computations: different keys, though the values agree.
    assert_ne!(key_of(&first, "off"), key_of(&first, "off0"), "unwired vs wired optional input");
    assert_ne!(key_of(&first, "off0"), key_of(&first, "off1"));

    // The second run is served from the cache entirely, through the pair's own codec.
    let decodes_before = PAIR_DECODES.load(Ordering::SeqCst);
    let second = run_ok(&p, PORT_TARGETS, &out, Some(cache_in(&cache_dir)), 2);
    assert_eq!(second.report.count(NodeStatus::Computed), 0, "{:#?}", second.report.nodes);
    for t in PORT_TARGETS {
        assert_eq!(second.report.status_of(t), Some(NodeStatus::Cached), "target {t}");
    }
    let decoded = PAIR_DECODES.load(Ordering::SeqCst) - decodes_before;
    // mm (2 ports), mmg (2), sum, off, off0, off1: 8 pairs.
    assert!(decoded >= 8, "the cache decoded only {decoded} pairs");
    assert_eq!(second.values.keys().collect::<Vec<_>>(), first.values.keys().collect::<Vec<_>>());
    for (name, v) in &first.values {
        let w = &second.values[name];
        assert_eq!(w.value_type(), v.value_type(), "{name}");
        assert!(!w.ptr_eq(v), "{name}: the cached value is a new value, decoded");
        let (mut a, mut b) = (Vec::new(), Vec::new());
        v.encode(&mut a);
        w.encode(&mut b);
        assert_eq!(a, b, "{name} after a round trip through the cache");
        if let Some(p) = v.get::<Pair>() {
            assert_eq!(w.get::<Pair>(), Some(p), "{name} after a round trip through the cache");
        }
    }
    for t in PORT_TARGETS {
        assert_eq!(key_of(&second, t), key_of(&first, t), "keys are stable across runs: {t}");
    }

    // Reordering the list changes Sum's key (and what it computes), and only what depends on it.
    let reordered = parse_ok(&ports_pipeline(r#"["mm.max", "mm2.max", "mm.min"]"#), &registry);
    let third = run_ok(&reordered, PORT_TARGETS, &out, Some(cache_in(&cache_dir)), 2);
    assert_ne!(key_of(&third, "sum"), key_of(&first, "sum"), "list order is in the key");
    assert_eq!(key_of(&third, "mm"), key_of(&first, "mm"));
    assert_eq!(pair(&third, "sum"), Pair(6.25, 2.0 + 2.0 * 2.0), "the new order reaches the operator");
    for (node, status) in [
        ("sum", NodeStatus::Computed),
        ("off", NodeStatus::Computed),
        ("off0", NodeStatus::Computed),
        ("off1", NodeStatus::Computed),
        ("mm", NodeStatus::Cached),
        ("mmg", NodeStatus::Cached),
        ("mm2", NodeStatus::Cached),
    ] {
        assert_eq!(third.report.status_of(node), Some(status), "{node} after reordering the list");
    }

    // The port taken is in the key: Sum of [mm.min] and Sum of [mm.max] differ only by the port.
    let min_only = parse_ok(&ports_pipeline(r#"["mm.min"]"#), &registry);
    let max_only = parse_ok(&ports_pipeline(r#"["mm.max"]"#), &registry);
    let k_min = scheduler::plan(&min_only, &["sum".into()], None).unwrap();
    let k_max = scheduler::plan(&max_only, &["sum".into()], None).unwrap();
    let sum_min = min_only.index_of("sum").unwrap();
    let sum_max = max_only.index_of("sum").unwrap();
    assert_ne!(k_min.keys[sum_min], k_max.keys[sum_max], "the port taken is in the key");
}

// ---------------------------------------------------------------------------------------------
// 2. Validation errors, with exact positions.
// ---------------------------------------------------------------------------------------------

#[test]
fn port_and_list_errors_name_file_line_and_column() {
    let registry = registry();
    let text = r#"(
    nodes: {
        "c": Constant(width: 2, height: 2),
        "mm": MinMax(image: "c"),
        "split": Split(image: "c"),
        "s1": Sum(values: ["mm.maxx"]),
        "s2": Sum(values: ["mm", "mm", "mm", "mm", "mm"]),
        "s3": Sum(values: []),
        "s4": Sum(values: ["mm.max", "split"]),
        "s5": Sum(values: "mm"),
        "o": Offset(value: "mm.nope"),
    },
)"#;
    let errors = parse_errors(text, &registry);
    let want = [
        r#"test.ron:6:28: node "s1": field "values": node "mm" has no output port "maxx"; did you mean "max"? (MinMax has ports: min, max)"#,
        r#"test.ron:7:27: node "s2": field "values" takes 1 to 4 nodes, found 5"#,
        r#"test.ron:8:27: node "s3": field "values" takes 1 to 4 nodes, found 0"#,
        // `Split` declares no port: a reference to it must name one.
        r#"test.ron:9:38: node "s4": field "values": node "split" has no default output: name one of its ports, e.g. "split.NAME" (Split has ports under any name: one channel, by name)"#,
        r#"test.ron:11:28: node "o": field "value": node "mm" has no output port "nope" (MinMax has ports: min, max)"#,
    ];
    assert_eq!(
        errors.len(),
        want.len(),
        "every problem is reported at once (a single name is a list of one):\n{}",
        errors.join("\n")
    );
    for (got, want) in errors.iter().zip(want) {
        assert_eq!(got, want);
    }
}

#[test]
fn wrong_element_types_in_lists_and_optional_inputs_name_file_line_and_column() {
    let registry = registry();
    let text = r#"(
    nodes: {
        "c": Constant(width: 2, height: 2),
        "mm": MinMax(image: "c"),
        "split": Split(image: "c"),
        "s": Sum(values: ["mm.min", "c", "mm.max"]),
        "t": Sum(values: ["split.R"]),
        "o": Offset(value: "mm", by: "c"),
    },
)"#;
    let mut errors = parse_errors(text, &registry);
    errors.sort();
    let want = [
        r#"test.ron:6:37: node "s": field "values" expects pair, but node "c" (Constant) gives image"#,
        r#"test.ron:7:27: node "t": field "values" expects pair, but port "split.R" (Split) gives scalar field"#,
        r#"test.ron:8:38: node "o": field "by" expects pair, but node "c" (Constant) gives image"#,
    ];
    assert_eq!(errors, want, "\n{}", errors.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// 3. The memory contract.
// ---------------------------------------------------------------------------------------------

fn ptr(node: &str) -> usize {
    *PTRS.lock().unwrap().get(node).unwrap_or_else(|| panic!("{node} recorded no buffer address"))
}

#[test]
fn the_only_consumer_takes_the_buffer_itself() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    let p = parse_ok(r#"( nodes: { "mem1_src": Source(size: 64), "mem1_take": Take(image: "mem1_src") } )"#, &registry);
    let outcome = run_ok(&p, &["mem1_take"], tmp.path(), None, 2);
    assert_eq!(
        ptr("mem1_take"),
        ptr("mem1_src"),
        "the only consumer of a node that is not a target must receive its buffer, not a copy"
    );
    let img = outcome.values["mem1_take"].get::<Image>().unwrap();
    assert!(img.data.iter().all(|&v| v == 2.0));
    assert_eq!(img.data.as_ptr() as usize, ptr("mem1_src"), "the target's value is that buffer too");

    // The same with a cache: storing the result must not keep a second reference to the buffer.
    let cache = tempfile::tempdir().unwrap();
    let outcome = run_ok(&p, &["mem1_take"], tmp.path(), Some(cache_in(cache.path())), 2);
    assert_eq!(outcome.report.count(NodeStatus::Computed), 2);
    assert_eq!(ptr("mem1_take"), ptr("mem1_src"), "with a cache, the only consumer must still receive the buffer");
}

#[test]
fn a_consumer_of_a_target_takes_a_copy_and_the_target_keeps_its_value() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    let p = parse_ok(r#"( nodes: { "mem2_src": Source(size: 64), "mem2_take": Take(image: "mem2_src") } )"#, &registry);
    let outcome = run_ok(&p, &["mem2_take", "mem2_src"], tmp.path(), None, 2);
    assert_ne!(ptr("mem2_take"), ptr("mem2_src"), "the source is a target: its consumer must copy");
    let src = outcome.values["mem2_src"].get::<Image>().unwrap();
    assert_eq!(src.data.as_ptr() as usize, ptr("mem2_src"), "the target keeps its own buffer");
    assert!(src.data.iter().all(|&v| v == 1.0), "the target's value was modified by its consumer");
    assert!(image(&outcome, "mem2_take").data.iter().all(|&v| v == 2.0));
}

#[test]
fn with_two_consumers_holding_the_value_take_copies() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    // Both consumers meet inside their evaluation, so both hold the value when `Take` takes it;
    // `Peek` then reads its input after `Take` has doubled its own.
    let p = parse_ok(
        r#"( nodes: {
            "mem3_src":  Source(size: 64),
            "mem3_take": Take(image: "mem3_src", meet: "mem3"),
            "mem3_peek": Peek(image: "mem3_src", meet: "mem3", after: "mem3_take"),
        } )"#,
        &registry,
    );
    run_ok(&p, &["mem3_take", "mem3_peek"], tmp.path(), None, 2);
    assert_ne!(ptr("mem3_take"), ptr("mem3_src"), "a value another consumer holds must be copied by take");
    assert_eq!(PEEKED.lock().unwrap()["mem3_peek"], (64 * 64 * 3) as f64, "the other consumer saw a change");
}

#[test]
fn values_are_dropped_after_their_last_consumer() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    let p = parse_ok(
        r#"( nodes: {
            "drop_a": TrackedMake(),
            "drop_b": TrackedStep(input: "drop_a"),
            "drop_c": TrackedSink(input: "drop_b"),
        } )"#,
        &registry,
    );
    let outcome = run_ok(&p, &["drop_c"], tmp.path(), None, 2);
    let seen = SEEN_DROPPED.lock().unwrap()["drop_c"].clone();
    assert_eq!(seen, ["drop_a"], "when c runs, a's value (consumed by b only) must be gone, and b's held");
    assert_eq!(
        dropped_with_prefix("drop"),
        ["drop_a", "drop_b"],
        "before the run returns, every value but the target's is dropped"
    );
    drop(outcome);
    assert_eq!(dropped_with_prefix("drop"), ["drop_a", "drop_b", "drop_c"], "the target's value goes with the outcome");
}

// ---------------------------------------------------------------------------------------------
// 4. Very long chains: no recursion grows with the graph.
// ---------------------------------------------------------------------------------------------

const CHAIN: usize = 100_000;

/// `n0 = Constant`, `n1..` = Exposure of the previous node, one node per line (node `ni` on line
/// `i + 3`).
fn chain_text(len: usize, last_lines: &[String]) -> String {
    let mut s = String::with_capacity(len * 48);
    s.push_str("(\n    nodes: {\n");
    s.push_str("        \"n0\": Constant(width: 1, height: 1, color: (0.25, 0.5, 1.0)),\n");
    for i in 1..len - last_lines.len() {
        s.push_str(&format!("        \"n{i}\": Exposure(image: \"n{}\", stops: 0.0),\n", i - 1));
    }
    for l in last_lines {
        s.push_str(l);
        s.push('\n');
    }
    s.push_str("    },\n)\n");
    s
}

/// Runs `f` on a thread with a 512 KiB stack.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new().stack_size(512 << 10).spawn(f).expect("spawning a thread").join().expect("no panic")
}

#[test]
fn a_100000_node_chain_validates_and_runs_on_a_small_stack() {
    let text = chain_text(CHAIN, &[]);
    let t0 = Instant::now();
    let (validated_ms, outcome_ok) = on_small_stack(move || {
        let registry = registry();
        let t = Instant::now();
        let p = parse_ok(&text, &registry);
        let validated_ms = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(p.nodes.len(), CHAIN);
        let tmp = tempfile::tempdir().unwrap();
        let last = format!("n{}", CHAIN - 1);
        let outcome = run_ok(&p, &[], tmp.path(), None, 2);
        assert_eq!(outcome.report.count(NodeStatus::Computed), CHAIN);
        let img = image(&outcome, &last);
        (validated_ms, img.data == [0.25, 0.5, 1.0])
    });
    assert!(outcome_ok, "Exposure(stops: 0) 99999 times keeps the colour");
    eprintln!(
        "100000-node chain: validated in {validated_ms:.0} ms, all in {:.0} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
}

/// Regression: the scheduler spawned every compute node whose pending count it found at 0 while
/// walking the node list, concurrently with the nodes already running; a node whose inputs had
/// finished in the meantime was spawned a second time (by its producer and by the walk), found
/// its input already taken and panicked ("a port's value stays until its last consumer").
#[test]
fn every_node_is_evaluated_once_while_roots_are_still_being_spawned() {
    const ROOTS: usize = 50_000;
    const LEN: usize = 20_000;
    // File order: the chain's root, many independent roots, then the chain. While the walk spawns
    // the roots, another worker runs the chain.
    let mut text = String::from("( nodes: {\n    \"tick_0\": Tick(),\n");
    for r in 0..ROOTS {
        text.push_str(&format!("    \"root_{r}\": PairConst(a: {r}, b: 0),\n"));
    }
    for i in 1..LEN {
        text.push_str(&format!("    \"tick_{i}\": Tick(input: \"tick_{}\"),\n", i - 1));
    }
    text.push_str("} )\n");
    let p = parse_ok(&text, &registry());
    let tmp = tempfile::tempdir().unwrap();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run(&p, &[], tmp.path(), None, 2).map(|o| o.report.count(NodeStatus::Computed))
    }));
    let ticks = TICKS.lock().unwrap().clone();
    let twice: Vec<&String> =
        ticks.iter().filter(|(n, c)| n.starts_with("tick_") && **c != 1).map(|(n, _)| n).collect();
    assert!(
        twice.is_empty(),
        "{} nodes were evaluated more than once, e.g. {:?}",
        twice.len(),
        &twice[..twice.len().min(5)]
    );
    match result {
        Ok(Ok(computed)) => assert_eq!(computed, ROOTS + LEN),
        Ok(Err(e)) => panic!("the run failed: {e}"),
        Err(_) => panic!("the run panicked (a node started twice finds its input already taken)"),
    }
    assert_eq!(ticks.keys().filter(|n| n.starts_with("tick_")).count(), LEN);
}

#[test]
fn a_100000_node_chain_with_a_cycle_at_its_end_reports_the_cycle() {
    // The last three nodes form a loop (n99997 also takes n99999), fed by the long chain.
    let (a, b, c) = (CHAIN - 3, CHAIN - 2, CHAIN - 1);
    let last = vec![
        format!("        \"n{a}\": Blend(image: \"n{}\", extra: \"n{c}\"),", a - 1),
        format!("        \"n{b}\": Exposure(image: \"n{a}\", stops: 0.0),"),
        format!("        \"n{c}\": Exposure(image: \"n{b}\", stops: 0.0),"),
    ];
    let text = chain_text(CHAIN, &last);
    let errors = on_small_stack(move || parse_errors(&text, &registry()));
    // Node n99997 is on line 99997 + 3; its operator `Blend` starts at column 19 (8 spaces,
    // the 9 characters of `"n99997":` and a space).
    let want = format!("test.ron:{}:19: node \"n{a}\": cycle: n{a} -> n{b} -> n{c} -> n{a}", a + 3);
    assert_eq!(errors, [want]);

    // A single loop through all 100000 nodes.
    let mut ring = chain_text(CHAIN, &[]);
    ring = ring.replace(
        "\"n0\": Constant(width: 1, height: 1, color: (0.25, 0.5, 1.0)),",
        &format!("\"n0\": Exposure(image: \"n{}\", stops: 0.0),", CHAIN - 1),
    );
    let errors = on_small_stack(move || parse_errors(&ring, &registry()));
    assert_eq!(errors.len(), 1, "one loop, one error");
    let names: Vec<&str> = errors[0].split_once("cycle: ").expect("a cycle message").1.split(" -> ").collect();
    assert_eq!(names.len(), CHAIN + 1, "the loop is named whole, closed by its first node");
    assert_eq!(names.first(), names.last());
    let index = |n: &str| n.trim_start_matches('n').parse::<usize>().expect("a chain node");
    for w in names.windows(2) {
        assert_eq!((index(w[0]) + 1) % CHAIN, index(w[1]), "{} -> {} is not an edge", w[0], w[1]);
    }
}

// ---------------------------------------------------------------------------------------------
// 5. --out and --cache-dir problems, through the binary.
// ---------------------------------------------------------------------------------------------

const SAVE_PIPELINE: &str = r#"(
    nodes: {
        "c":    Constant(width: 4, height: 2, color: 0.5),
        "e":    Exposure(image: "c", stops: 1.0),
        "save": Save(input: "e", path: "e.pfm"),
    },
)"#;

#[test]
fn out_naming_a_regular_file_fails_before_anything_is_computed() {
    let sb = Sandbox::new();
    let graph = sb.write("g.ron", SAVE_PIPELINE);
    let out = sb.write("not-a-folder", "precious");
    let report = sb.join("report.json");
    let o = common::run_command(sb.run_command(&graph, &out, &sb.cache(), &report, &[]), RUN_TIMEOUT);
    // A usage error (issue 25.8).
    o.assert_code(2).assert_stderr_contains(&format!("--out {}: is a file; --out names the folder", out.display()));
    assert!(!o.stderr.contains("computed"), "something was computed:\n{}", o.describe());
    assert!(!report.exists(), "a failed run wrote its report");
    assert_eq!(files_under(&sb.cache()), Vec::<std::path::PathBuf>::new(), "the cache received entries");
    assert_eq!(std::fs::read(&out).unwrap(), b"precious", "the file named by --out was touched");
}

#[test]
fn an_unusable_cache_folder_is_one_warning_and_the_run_succeeds() {
    let sb = Sandbox::new();
    let graph = sb.write("g.ron", SAVE_PIPELINE);
    let cache = sb.write("cache-is-a-file", "not a folder");
    let report = sb.join("report.json");
    let o = common::run_command(sb.run_command(&graph, &sb.out(), &cache, &report, &[]), RUN_TIMEOUT);
    o.assert_success();
    let warnings: Vec<&str> = o.stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "expected exactly one warning line:\n{}", o.describe());
    assert!(warnings[0].starts_with("warning: "), "{}", warnings[0]);
    assert!(warnings[0].contains("running without the cache"), "{}", warnings[0]);
    let img = hdrflow::formats::pfm::decode(&common::read_file(&sb.out().join("e.pfm"))).unwrap();
    assert!(img.data.iter().all(|&v| v == 1.0));
    assert!(report.exists());
    assert_eq!(std::fs::read(&cache).unwrap(), b"not a folder");
}

// ---------------------------------------------------------------------------------------------
// 6. The type contract.
// ---------------------------------------------------------------------------------------------

#[test]
fn an_operator_breaking_its_declaration_is_a_contract_error() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    for (lie, what) in
        [("WrongType", "output \"a\" is a image, but Liar declares pair"), ("MissingPort", "no output \"b\"")]
    {
        let p = parse_ok(&format!(r#"( nodes: {{ "liar": Liar(lie: {lie}) }} )"#), &registry);
        let cache = cache_in(&tmp.path().join("cache"));
        let err = match run(&p, &[], tmp.path(), Some(cache.clone()), 1) {
            Ok(_) => panic!("{lie}: the run succeeded"),
            Err(e) => e,
        };
        let msg = err.to_string();
        assert!(matches!(&err, RunError::Contract { node, op: "Liar", .. } if node == "liar"), "{lie}: {err:?}");
        assert!(msg.contains("a bug in the operator"), "{lie}: {msg}");
        assert!(msg.contains(what), "{lie}: {msg}");
        // Nothing was stored under the node's key.
        let plan = scheduler::plan(&p, &[], Some(&cache)).unwrap();
        assert_eq!(plan.status, [NodeStatus::Computed], "{lie}: a broken result was cached");
    }
}

// ---------------------------------------------------------------------------------------------
// 7. RGBA EXR, bit for bit.
// ---------------------------------------------------------------------------------------------

#[test]
fn rgba_exr_round_trips_bit_for_bit_through_loadhdr_and_save() {
    let sb = Sandbox::new();
    let (w, h) = (7usize, 5usize);
    // Distinct values per channel and pixel, with awkward ones: -0, a subnormal, beyond half range.
    let value = |x: usize, y: usize, c: usize| -> f32 {
        let i = (y * w + x) * 4 + c;
        match i % 11 {
            0 => -0.0,
            1 => 1.0e-40,
            2 => 69120.5,
            _ => (i as f32) * 0.37 - 3.0,
        }
    };
    let alpha = |x: usize, y: usize| -> f32 { (y * w + x) as f32 / (w * h) as f32 + 0.001 };
    let input = sb.join("rgba.exr");
    exr::prelude::write_rgba_file(&input, w, h, |x, y| (value(x, y, 0), value(x, y, 1), value(x, y, 2), alpha(x, y)))
        .expect("writing the test EXR");
    let graph = sb.write(
        "g.ron",
        format!(
            r#"( nodes: {{ "env": LoadHdr(path: {}), "save": Save(input: "env", path: "x.exr") }} )"#,
            ron_path(&input)
        ),
    );
    sb.run_ok(&graph, &[]);

    let back = exr::prelude::read_all_flat_layers_from_file(sb.out().join("x.exr")).expect("reading x.exr back");
    assert_eq!(back.layer_data.len(), 1);
    let layer = &back.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (w, h));
    let mut names = Vec::new();
    for ch in &layer.channel_data.list {
        let name = ch.name.to_string();
        let exr::prelude::FlatSamples::F32(samples) = &ch.sample_data else {
            panic!("channel {name} is not stored as f32");
        };
        let c = ["R", "G", "B", "A"].iter().position(|n| *n == name).unwrap_or_else(|| panic!("channel {name}"));
        for y in 0..h {
            for x in 0..w {
                let want = if c == 3 { alpha(x, y) } else { value(x, y, c) };
                let got = samples[y * w + x];
                assert_eq!(got.to_bits(), want.to_bits(), "channel {name} at ({x}, {y}): {got:e} vs {want:e}");
            }
        }
        names.push(name);
    }
    names.sort();
    assert_eq!(names, ["A", "B", "G", "R"]);
}

// ---------------------------------------------------------------------------------------------
// 8. Samples from a distribution over another resolution than the map.
// ---------------------------------------------------------------------------------------------

/// Per-channel mean over the inscribed disc of a square image.
fn disc_mean(img: &Image) -> [f64; 3] {
    let mask = hdrflow::ops::image::image_error::sphere_mask(img.width);
    let mut sum = [0.0f64; 3];
    let mut n = 0usize;
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        let (x, y) = (i % img.width, i / img.width);
        let p = img.rgb(x, y);
        for c in 0..3 {
            sum[c] += p[c] as f64;
        }
        n += 1;
    }
    sum.map(|s| s / n as f64)
}

fn relative_errors(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| (a[c] / b[c] - 1.0).abs())
}

#[test]
fn relighting_with_samples_from_a_coarser_distribution() {
    let registry = registry();
    let tmp = tempfile::tempdir().unwrap();
    let text = r#"(
    nodes: {
        "sky":    LoadHdr(path: "builtin:sky"),
        "env":    Resize(image: "sky", width: 256, height: 128),
        "small":  Resize(image: "env", width: 64, height: 32),
        "lum_s":  Luminance(image: "small"),
        "cdf_s":  BuildCdf(luminance: "lum_s"),
        "smp_s":  Sample(cdf: "cdf_s", count: 65536, sequence: Stratified),
        "lum_f":  Luminance(image: "env"),
        "cdf_f":  BuildCdf(luminance: "lum_f"),
        "smp_f":  Sample(cdf: "cdf_f", count: 65536, sequence: Stratified),
        "ref":    ReferenceSphere(env: "env", size: 64),
        "unb_s":  RelightSphere(env: "env", samples: "smp_s", size: 64, estimator: Unbiased),
        "unb_f":  RelightSphere(env: "env", samples: "smp_f", size: 64, estimator: Unbiased),
        "seed_s": RelightSphere(env: "env", samples: "smp_s", size: 64, estimator: Seed),
        "seed_f": RelightSphere(env: "env", samples: "smp_f", size: 64, estimator: Seed),
        // Diagnostics only (no assertion): radiance looked up in the map the distribution was
        // built from, i.e. averaged over each coarse texel's footprint.
        "unb_c":  RelightSphere(env: "small", samples: "smp_s", size: 64, estimator: Unbiased),
        "seed_c": RelightSphere(env: "small", samples: "smp_s", size: 64, estimator: Seed),
    },
)"#;
    let p = parse_ok(text, &registry);
    let targets = ["ref", "unb_s", "unb_f", "seed_s", "seed_f", "unb_c", "seed_c", "cdf_s", "cdf_f"];
    let v = run_ok(&p, &targets, tmp.path(), None, 2);
    let m = |n: &str| disc_mean(&image(&v, n));
    let (reference, unb_s, unb_f, seed_s, seed_f) = (m("ref"), m("unb_s"), m("unb_f"), m("seed_s"), m("seed_f"));
    let (unb_c, seed_c) = (m("unb_c"), m("seed_c"));
    let lum = |c: [f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let avg = |c: [f64; 3]| (c[0] + c[1] + c[2]) / 3.0;
    let integral = |n: &str| v.values[n].get::<hdrflow::values::Distribution2D>().unwrap().luminance_integral();
    let report = format!(
        "disc means (R, G, B):\n  ReferenceSphere        {reference:?}\n  Unbiased, 64x32 cdf    {unb_s:?} (rel. err {:?})\n  \
         Unbiased, 256x128 cdf  {unb_f:?} (rel. err {:?})\n  Seed, 64x32 cdf        {seed_s:?}\n  Seed, 256x128 cdf      {seed_f:?} \
         (64x32 vs 256x128: {:?}; of the channel mean {:e}, of the luminance {:e})\n\
         luminance integrals: 64x32 {}, 256x128 {}\n\
         diagnostics, radiance from the 64x32 map itself:\n  \
         Unbiased  {unb_c:?} (rel. err vs reference {:?})\n  \
         Seed      {seed_c:?} (vs Seed 256x128: {:?})",
        relative_errors(unb_s, reference),
        relative_errors(unb_f, reference),
        relative_errors(seed_s, seed_f),
        (avg(seed_s) / avg(seed_f) - 1.0).abs(),
        (lum(seed_s) / lum(seed_f) - 1.0).abs(),
        integral("cdf_s"),
        integral("cdf_f"),
        relative_errors(unb_c, reference),
        relative_errors(seed_c, seed_f),
    );
    eprintln!("{report}");
    // Sanity: with the map's own distribution the unbiased estimate converges to the reference.
    assert!(relative_errors(unb_f, reference).iter().all(|e| *e < 0.02), "{report}");
    assert!(relative_errors(unb_s, reference).iter().all(|e| *e < 0.02), "Unbiased, 64x32 distribution:\n{report}");
    assert!(relative_errors(seed_s, seed_f).iter().all(|e| *e < 0.03), "Seed, 64x32 vs 256x128:\n{report}");
}

/// A Save target's value, once its file is written, keeps the file's path and not its bytes (the
/// run does not hold a large file to its end); a second run from the cache writes the same file.
#[test]
fn a_written_file_is_kept_as_its_path() {
    use hdrflow::engine::value::FileBlob;
    let r = registry();
    let p = parse_ok(
        r#"( nodes: { "c": Constant(width: 64, height: 32, color: (0.25, 0.5, 2.0)), "save": Save(input: "c", path: "c.pfm") } )"#,
        &r,
    );
    let sandbox = Sandbox::new();
    let out = sandbox.join("out");
    for pass in ["computed", "cached"] {
        let outcome = run_ok(&p, &["save"], &out, Some(cache_in(&sandbox.join("cache"))), 2);
        let want = if pass == "computed" { NodeStatus::Computed } else { NodeStatus::Cached };
        assert_eq!(outcome.report.nodes.iter().find(|n| n.name == "save").map(|n| n.status), Some(want));
        let f = outcome.values["save"].get::<FileBlob>().expect("the Save value");
        assert_eq!((f.rel_path.as_str(), f.bytes.len()), ("c.pfm", 0), "{pass}");
        let written = std::fs::read(out.join("c.pfm")).expect("the file");
        assert_eq!(written.len(), 64 * 32 * 12 + "PF\n64 32\n-1.0\n".len(), "{pass}");
    }
}

/// A node in error does not hide the problems of the nodes after it that do not depend on it:
/// an unknown field (phase 4) or a wrong input type (phase 6) leaves the node's fixed output
/// type in place, so its saver's extension is still checked, in the same run.
#[test]
fn a_node_in_error_does_not_hide_the_independent_errors_after_it() {
    let registry = registry();
    for cdf in [r#"BuildCdf(luminance: "lum", bogus: 1)"#, r#"BuildCdf(luminance: "env")"#] {
        let text = format!(
            "(nodes: {{\n    \"env\": LoadHdr(path: \"builtin:sky\"),\n    \"lum\": Luminance(image: \"env\"),\n    \
             \"cdf\": {cdf},\n    \"save\": Save(input: \"cdf\", path: \"c.jpg\"),\n}})"
        );
        let errors = parse_errors(&text, &registry);
        assert_eq!(errors.len(), 2, "{errors:#?}");
        assert!(errors[0].starts_with("test.ron:4:") && errors[0].contains("node \"cdf\""), "{errors:#?}");
        assert!(errors[1].contains("test.ron:5:") && errors[1].contains("as \".jpg\""), "{errors:#?}");
    }
}

/// Validation finds a missing input file at its field; a file that vanishes after validation
/// still fails the run, at its loader, naming the file.
#[test]
fn a_missing_input_file_fails_validation_and_one_that_vanishes_later_fails_the_run() {
    let sb = Sandbox::new();
    let registry = registry();
    let text = r#"(nodes: { "env": LoadHdr(path: "m.pfm"), "e": Exposure(image: "env", stops: 1) })"#;
    let errors = Pipeline::parse(text, "t.ron", sb.path(), &registry, &[]).unwrap_err().to_string();
    assert!(
        errors.starts_with(r#"t.ron:1:32: node "env": field "path": input file "m.pfm" does not exist"#),
        "{errors}"
    );

    let map = sb.write("m.pfm", common::small_pfm(4, 2, 1.0));
    let p = Pipeline::parse(text, "t.ron", sb.path(), &registry, &[]).expect("the file is there");
    std::fs::remove_file(&map).unwrap();
    let Err(err) = run(&p, &["e"], &sb.out(), None, 2) else { panic!("the run succeeded without its file") };
    let err = err.to_string();
    assert!(err.contains("node \"env\"") && err.contains("m.pfm"), "{err}");
}
