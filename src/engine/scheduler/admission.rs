//! Step 5 of a run (see the module doc of `scheduler`): which ready node starts next, and when a
//! node that makes a large value waits for memory to be freed first.
//!
//! The run counts the bytes it holds (`live`): every value in a port slot, every value a running
//! node took as its last consumer (until the node finishes, or hands it back early with
//! `OpContext::release`), and the predicted output of every running node. A prediction is the
//! node's output size known before running (`Node::size`, from file headers and parameters)
//! times the bytes a texel took in the values of its type the run has already held (the most
//! seen: 12 for an RGB f32 image, 4 for a luminance, 8 for a distribution, almost 0 for a set of
//! samples drawn over a map's grid); 0 for a node whose size is unknown, or the first of its type.
//!
//! - **Order.** Among the ready nodes the one that lowers `live` the most starts first: the
//!   bytes of the inputs it is the last consumer of (as of when it was queued) minus its
//!   prediction; then the earliest in file order. A node that frees a distribution, or makes a
//!   small result from one, goes before one that draws a new map.
//! - **Admission.** A node predicted large (16 MiB or more) starts only if `live` plus its
//!   prediction stays within `high` (plus 16 MiB, the slack of small values), or when no other
//!   node is running; `high` is the most a large node's start has needed so far, and the second
//!   way raises it. So the run does not raise its peak while other work can go on without
//!   raising it, and it always moves on. A node with nothing to predict from (the first of its
//!   type) whose size could make it large (1 Mi texels: 16 MiB at 16 bytes a texel) starts only
//!   when no other node is running, and `high` then takes what the run holds once it has
//!   finished: the first distribution of a map is built alone, so the second waits for it and
//!   its prediction. Small nodes never wait, so runs on small maps keep all their parallelism.
//!
//! What the count does not see: buffers an operator allocates and frees inside its `eval` (a
//! PNG's 8-bit copy), and values a non-last consumer still holds after the last has finished.
//! It orders starts; it is never a limit that fails a run. Measured on `graphs/seed.ron`:
//! docs/src/benchmarks/engine.md, "Peak memory".
//!
//! The queue is a heap by the order above; a pop skips (and keeps) the large nodes that may not
//! start, and ranks again an entry whose prediction has changed since it was queued, so it costs
//! O(k log n) for k of them.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::sync::Mutex;

use crate::engine::value::ValueType;

/// Predictions below this never wait, and this much above `high` is still within it.
const SMALL: usize = 16 << 20;

/// Texels from which a node of a type not seen yet could be large (`SMALL` at 16 bytes a texel).
const PROBE_TEXELS: u64 = (SMALL / 16) as u64;

/// What the run expects a node to make.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Prediction {
    /// Bytes (0 when its size is unknown, or small and of a type not seen yet).
    Bytes(usize),
    /// Of a type not seen yet, and large enough to matter: it starts alone.
    Unknown,
}

#[derive(Debug)]
struct Inner {
    /// (bytes it lowers `live` by, earliest in file order first, bytes its start frees). The
    /// first is as of when the entry was made: a prediction only grows (from nothing to what
    /// its type takes, then to the most seen), so a stale entry ranks too high, and `pop`
    /// ranks it again.
    heap: BinaryHeap<(i64, Reverse<usize>, usize)>,
    /// Per node: its default output's type and pixel count, when known before running.
    shapes: Vec<Option<(ValueType, u64)>>,
    /// Per type: the most bytes a texel took in a value of it so far.
    texel_bytes: HashMap<ValueType, f64>,
    /// Per node: the prediction counted while it runs.
    counted: Vec<usize>,
    /// Per node: it started alone, with nothing to predict from.
    probing: Vec<bool>,
    /// Per node: bytes of the inputs it took as their last consumer and still holds.
    held: Vec<usize>,
    live: usize,
    high: usize,
    running: usize,
}

impl Inner {
    /// The bytes starting `node` lowers `live` by: what it frees minus what it is predicted to make.
    fn gain(&self, node: usize, frees: usize) -> i64 {
        let made = match self.predicted(node) {
            Prediction::Bytes(b) => b,
            Prediction::Unknown => 0,
        };
        frees as i64 - made as i64
    }

    fn predicted(&self, node: usize) -> Prediction {
        match self.shapes[node] {
            Some((ty, pixels)) => match self.texel_bytes.get(&ty) {
                Some(b) => Prediction::Bytes((b * pixels as f64) as usize),
                None if pixels >= PROBE_TEXELS => Prediction::Unknown,
                None => Prediction::Bytes(0),
            },
            None => Prediction::Bytes(0),
        }
    }
}

/// The ready nodes and the run's count of bytes held (see the module documentation).
#[derive(Debug)]
pub(super) struct Admission(Mutex<Inner>);

impl Admission {
    /// `shapes[i]`: node i's default output type and pixel count, when known before running.
    pub fn new(shapes: Vec<Option<(ValueType, u64)>>) -> Admission {
        let n = shapes.len();
        Admission(Mutex::new(Inner {
            heap: BinaryHeap::new(),
            shapes,
            texel_bytes: HashMap::new(),
            counted: vec![0; n],
            probing: vec![false; n],
            held: vec![0; n],
            live: 0,
            high: 0,
            running: 0,
        }))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.0.lock().expect("admission lock")
    }

    /// Queues node `node`, whose start frees `frees` bytes (the inputs it is the last consumer of).
    pub fn push(&self, node: usize, frees: usize) {
        let mut m = self.lock();
        let gain = m.gain(node, frees);
        m.heap.push((gain, Reverse(node), frees));
    }

    /// The best queued node that may start now (see the module documentation), counted as
    /// running from here on; None if the queue is empty or every queued node must wait.
    pub fn pop(&self) -> Option<usize> {
        let mut m = self.lock();
        let mut waiting = Vec::new();
        let mut chosen = None;
        while let Some(entry) = m.heap.pop() {
            let (gain, Reverse(node), frees) = entry;
            let now = m.gain(node, frees);
            if now != gain {
                // Its type was seen since it was queued: ranked again, where it now belongs.
                m.heap.push((now, Reverse(node), frees));
                continue;
            }
            let prediction = m.predicted(node);
            let starts = match prediction {
                Prediction::Bytes(p) => p < SMALL || m.live + p <= m.high + SMALL || m.running == 0,
                Prediction::Unknown => m.running == 0,
            };
            if starts {
                chosen = Some((node, prediction));
                break;
            }
            waiting.push(entry);
        }
        m.heap.extend(waiting);
        let (node, prediction) = chosen?;
        m.running += 1;
        match prediction {
            Prediction::Bytes(p) => {
                m.live += p;
                m.counted[node] = p;
                if p >= SMALL {
                    m.high = m.high.max(m.live);
                }
            }
            Prediction::Unknown => m.probing[node] = true,
        }
        Some(node)
    }

    /// Whether nodes are queued.
    pub fn has_queued(&self) -> bool {
        !self.lock().heap.is_empty()
    }

    /// A value of `bytes` was put in a port slot; `shape`: its type and pixel count, when it is
    /// a node's default output of a size known before running (what predictions learn from).
    pub fn stored(&self, bytes: usize, shape: Option<(ValueType, u64)>) {
        let mut m = self.lock();
        m.live += bytes;
        if let Some((ty, pixels)) = shape.filter(|s| s.1 > 0) {
            let per_texel = bytes as f64 / pixels as f64;
            let known = m.texel_bytes.entry(ty).or_insert(per_texel);
            *known = known.max(per_texel);
        }
    }

    /// Running node `node` took a value of `bytes` out of its slot as its last consumer (still
    /// held, now by the node).
    pub fn took(&self, node: usize, bytes: usize) {
        self.lock().held[node] += bytes;
    }

    /// Running node `node` dropped an input of `bytes` it had taken as the last consumer.
    pub fn released(&self, node: usize, bytes: usize) {
        let mut m = self.lock();
        let b = bytes.min(m.held[node]);
        m.held[node] -= b;
        m.live = m.live.saturating_sub(b);
    }

    /// Node `node` has finished (its outputs are in their slots): its prediction and the inputs
    /// it held are no longer counted.
    pub fn finished(&self, node: usize) {
        let mut m = self.lock();
        let gone = std::mem::take(&mut m.counted[node]) + std::mem::take(&mut m.held[node]);
        m.live = m.live.saturating_sub(gone);
        m.running = m.running.saturating_sub(1);
        if std::mem::take(&mut m.probing[node]) {
            m.high = m.high.max(m.live);
        }
    }

    /// (live, high, running), for tests.
    #[cfg(test)]
    fn counts(&self) -> (usize, usize, usize) {
        let m = self.lock();
        (m.live, m.high, m.running)
    }
}

#[cfg(test)]
mod tests {
    use super::{Admission, Prediction, PROBE_TEXELS};
    use crate::values::ty::{DISTRIBUTION_T, IMAGE_T, SAMPLES_T};

    const MB: usize = 1 << 20;
    /// Pixels of a 400 MB RGB f32 map (12 bytes a texel).
    const MAP: u64 = 400 * MB as u64 / 12;

    /// Without predictions the order is by bytes freed, then file order.
    #[test]
    fn the_node_that_frees_most_starts_first_then_file_order() {
        let q = Admission::new(vec![None; 8]);
        for (frees, node) in [(0, 4), (100, 7), (0, 2), (100, 3), (5, 0)] {
            q.push(node, frees);
        }
        let order: Vec<usize> = std::iter::from_fn(|| q.pop()).collect();
        assert_eq!(order, [3, 7, 0, 2, 4]);
    }

    /// Predictions come from the values of the type held so far: nothing before the first,
    /// then the most bytes a texel took.
    #[test]
    fn a_prediction_is_the_size_times_what_a_texel_of_the_type_took() {
        let q = Admission::new(vec![Some((IMAGE_T, MAP)), Some((IMAGE_T, MAP / 4)), Some((SAMPLES_T, MAP))]);
        assert_eq!(q.lock().predicted(0), Prediction::Unknown, "no image seen yet");
        q.stored(400 * MB, Some((IMAGE_T, MAP)));
        q.stored(MB, Some((SAMPLES_T, MAP)));
        let bytes = |n| match q.lock().predicted(n) {
            Prediction::Bytes(b) => b,
            Prediction::Unknown => panic!("node {n}: its type was seen"),
        };
        assert!(bytes(0).abs_diff(400 * MB) <= 1, "{}", bytes(0));
        assert!(bytes(1).abs_diff(100 * MB) <= 16, "{}", bytes(1));
        assert!(bytes(2).abs_diff(MB) <= 1, "samples drawn on the map's grid are small: {}", bytes(2));
    }

    /// A node that makes a large value goes after one that makes a small one, and after one
    /// that frees more than it makes.
    #[test]
    fn the_order_counts_what_a_node_makes_against_what_it_frees() {
        let q = Admission::new(vec![Some((IMAGE_T, MAP)), Some((IMAGE_T, MAP / 400)), Some((IMAGE_T, 3 * MAP / 4))]);
        q.stored(400 * MB, Some((IMAGE_T, MAP)));
        q.push(0, 0);
        q.push(1, 0);
        q.push(2, 400 * MB);
        // One at a time, each finished before the next starts (so none waits for memory).
        let order: Vec<usize> = std::iter::from_fn(|| q.pop().inspect(|&n| q.finished(n))).collect();
        assert_eq!(order, [2, 1, 0]);
    }

    /// A large node waits while the run would go past the most a large start has needed and
    /// something else runs, and starts as soon as enough is handed back; with nothing else
    /// running it starts anyway and raises that mark.
    #[test]
    fn a_large_node_waits_for_memory_while_others_run() {
        // Node 0: a 400 MB map; 1 and 2: overlays of 400 MB each; 3: the save of overlay 1
        // (small output); 4: small.
        let image = Some((IMAGE_T, MAP));
        let q = Admission::new(vec![image, image, image, None, None]);
        q.push(0, 0);
        assert_eq!(q.pop(), Some(0), "the first image: nothing to predict from, nothing else runs");
        q.stored(400 * MB, image);
        q.finished(0);
        assert_eq!(q.counts(), (400 * MB, 400 * MB, 0), "what the run holds after it is the mark");
        q.push(4, 0);
        q.push(1, 0);
        q.push(2, 0);
        assert_eq!(q.pop(), Some(4), "a small node never waits");
        assert_eq!(q.pop(), None, "an overlay would go past the mark while node 4 runs");
        q.finished(4);
        assert_eq!(q.pop(), Some(1), "nothing else runs: it starts");
        assert_eq!(q.counts(), (800 * MB, 800 * MB, 1));
        assert_eq!(q.pop(), None, "a second overlay would raise the peak while the first runs");
        q.stored(400 * MB, image);
        q.finished(1);
        q.push(3, 400 * MB);
        assert_eq!(q.pop(), Some(3), "the save frees the overlay: before the second overlay");
        q.took(3, 400 * MB);
        assert_eq!(q.pop(), None, "the save still holds the first overlay");
        q.released(3, 400 * MB);
        assert_eq!(q.pop(), Some(2), "handed back early: the second overlay may start");
        assert_eq!(q.counts(), (800 * MB, 800 * MB, 2));
        q.finished(3);
        assert_eq!(q.counts(), (800 * MB, 800 * MB, 1), "what was released is not subtracted twice");
    }

    /// Small values alive beside (a few saved files) do not hold back a start that needs what
    /// an earlier one did.
    #[test]
    fn small_values_alive_beside_are_within_the_slack() {
        let image = Some((IMAGE_T, MAP));
        let q = Admission::new(vec![image, image, None]);
        q.stored(400 * MB, image);
        q.push(0, 0);
        assert_eq!(q.pop(), Some(0));
        q.finished(0);
        q.stored(5 * MB, None);
        q.push(2, 0);
        assert_eq!(q.pop(), Some(2));
        q.push(1, 0);
        assert_eq!(q.pop(), Some(1), "405 MB + 400 MB is within 800 MB and the slack");
    }

    /// The first node of a type, large enough to matter, starts alone: the second of the type
    /// then has a prediction and waits for memory.
    #[test]
    fn the_first_large_node_of_a_type_starts_alone() {
        // 0: small; 1 and 2: distributions of a map; 3: a distribution too small to matter.
        let dist = Some((DISTRIBUTION_T, MAP));
        let q = Admission::new(vec![None, dist, dist, Some((DISTRIBUTION_T, PROBE_TEXELS - 1))]);
        q.stored(500 * MB, None);
        for n in [3, 1, 2] {
            q.push(n, 0);
        }
        assert_eq!(q.pop(), Some(1), "nothing runs: the first distribution starts");
        assert_eq!(q.pop(), Some(3), "the second waits; one too small to matter does not");
        q.finished(3);
        assert_eq!(q.pop(), None);
        q.stored(267 * MB, dist);
        q.finished(1);
        assert_eq!(q.counts(), (767 * MB, 767 * MB, 0), "the mark: what the run holds after it");
        let Prediction::Bytes(b) = q.lock().predicted(2) else { panic!("a distribution was seen") };
        assert!(b.abs_diff(267 * MB) <= 1, "{b}");
        q.push(0, 0);
        assert_eq!(q.pop(), Some(0));
        assert_eq!(q.pop(), None, "767 + 267 MB is past the mark while node 0 runs");
        q.finished(0);
        assert_eq!(q.pop(), Some(2), "nothing else runs");
    }

    /// A node queued before its type was seen is ranked by what it makes once that is known: a
    /// second distribution that frees a luminance does not go before a small node any more.
    #[test]
    fn a_node_is_ranked_again_once_its_type_is_seen() {
        // 0: a glossy sphere (a small image); 1: a distribution of a map.
        let q = Admission::new(vec![Some((IMAGE_T, MAP / 4096)), Some((DISTRIBUTION_T, MAP))]);
        q.stored(400 * MB, Some((IMAGE_T, MAP)));
        q.push(1, 100 * MB);
        q.push(0, 0);
        q.stored(267 * MB, Some((DISTRIBUTION_T, MAP)));
        assert_eq!(q.pop(), Some(0), "the distribution now makes more than it frees");
        q.finished(0);
        assert_eq!(q.pop(), Some(1));
    }
}
