//! What a render computes before it reads the map, kept for the next render of the same frame.
//!
//! A sphere's camera rays, their hits on the mesh, its coverage and, for the mirror, each ray's
//! reflection and Fresnel weight depend on the frame (size, samples, shape, material) and not on
//! the map. An evaluation renders the same three frames under every map (a prediction and a ground
//! truth per scene, at every checkpoint), so the [`Plan`] of a frame is made once per process and
//! shared: a later render reads the map along the stored rays (the mirror) or shades the stored
//! hits (the rough lobes). The plan is the same whether it was stored or made afresh, so a render
//! is the same bit for bit either way.
//!
//! The store holds at most [`KEPT`] plans of at most [`MAX_BYTES`] each (a 960 x 540 mirror's
//! holds about 120 MB; the two rough materials share one plan). A mirror's plan also keeps its
//! reads merged by texel ([`super::mirror_reads`]) for the last [`KEPT_SIZES`] map sizes it read,
//! which [`MAX_BYTES`] does not count: at most 4/3 of the rays' bytes a size (a few MB at 960 x 540
//! and a 256 x 128 map, where a pixel's rays share a few texels).
//!
//! **Between processes.** Given a [`PlanStore`] (the run's persistent cache, through the
//! operator), a plan's stages and a mirror's reads of each map size are also kept there, and a
//! process that finds them reads them instead of tracing (a later checkpoint's run, a cluster's
//! shard): seconds saved a frame. A plan read back has no rays; should it need the reads of a map
//! size the store does not have, it traces its rays again (the same rays: the trace is
//! deterministic).
//!
//! A plan and its reads are made on their own thread pool from a plain thread: a rayon worker
//! that waits for them blocks rather than steals, so no worker can start another render that
//! waits for the same plan on top of the one making it.

use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use super::interpolation::{self, Fill};
use super::mirror_reads::RowReads;
use super::plan_bytes::{decode_reads, decode_stages, encode_reads, encode_stages, PlanStore};
use super::principled::Principled;
use super::recent::{recent_slot, Recent};
use super::tiles::{self, Tile};
use super::{scene, trace_row, MirrorRay, ProbeMaterial, ProbeSettings, ProbeShape, Stage};

/// How many plans the process keeps (the least recently used dropped first).
const KEPT: usize = 4;
/// Plans larger than this are made for their render only.
const MAX_BYTES: usize = 1 << 30;
/// How many map sizes a mirror plan keeps its reads for.
const KEPT_SIZES: usize = 2;
/// How many rough materials a plan keeps its interpolation masks and tiles for (the protocol has
/// two).
const KEPT_MATERIALS: usize = 2;

/// A frame's tiles of one rough material, a list per band of tile rows.
pub(super) type BandTiles = Vec<Vec<Tile>>;

/// The stages of every pixel (row-major) and each row's mirror rays.
pub(super) struct Plan {
    /// what the plan was made for (to trace its rays again) and its name in a [`PlanStore`]
    settings: ProbeSettings,
    name: String,
    pub(super) stages: Vec<Stage>,
    /// each row's columns from its first to its last stage that is not empty (`Done(0.0)`, off
    /// the sphere): the passes of a render over every pixel read these alone, about a sixth of a
    /// protocol frame's 62 MB of stages
    pub(super) spans: Vec<Range<usize>>,
    /// made with the stages, or traced again when a plan read from a store needs them
    rays: OnceLock<Vec<Vec<MirrorRay>>>,
    /// the mirror's reads of each map size (width, height), most recently used last
    reads: Recent<(usize, usize), Arc<Vec<RowReads>>>,
    /// how each rough material gets each pixel: shaded or interpolated ([`interpolation`])
    fills: Recent<Principled, Arc<Vec<Fill>>>,
    /// each rough material's tiles, by tile side and whether it interpolates: a list per band of
    /// tile rows ([`tiles::band_tiles`])
    tiles: Recent<(Principled, usize, bool), Arc<BandTiles>>,
}

impl Plan {
    /// The frame's width, pixels.
    fn width(&self) -> usize {
        self.settings.width
    }

    /// Each row's mirror rays.
    fn rays(&self) -> &Vec<Vec<MirrorRay>> {
        self.rays.get_or_init(|| trace(&self.settings).1)
    }

    /// [`interpolation::fills`] of `bsdf` on this frame: the kept ones, or made now.
    pub(super) fn fills(&self, bsdf: &Principled) -> Arc<Vec<Fill>> {
        let slot = recent_slot(&self.fills, *bsdf, KEPT_MATERIALS);
        slot.get_or_init(|| Arc::new(on_own_pool(|_| interpolation::fills(&self.stages, self.width(), bsdf)))).clone()
    }

    /// The tiles of `bsdf` on this frame, `tile` pixels a side, with the pixels
    /// [`Plan::fills`] marks to shade when `interpolate` (else every pixel), a list per
    /// band of `tile` rows: the kept ones, or made now.
    pub(super) fn tiles(&self, bsdf: &Principled, tile: usize, interpolate: bool) -> Arc<BandTiles> {
        let slot = recent_slot(&self.tiles, (*bsdf, tile, interpolate), KEPT_MATERIALS);
        if let Some(tiles) = slot.get() {
            return tiles.clone();
        }
        let shade = if interpolate { self.fills(bsdf) } else { Arc::new(vec![Fill::Shade; self.stages.len()]) };
        slot.get_or_init(|| {
            let band = tile.max(1) * self.width().max(1);
            let tiles_of = |b: usize| {
                let pixels = b * band..((b + 1) * band).min(self.stages.len());
                tiles::band_tiles(bsdf, (self.width(), &self.stages[pixels.clone()], &shade[pixels]), tile.max(1))
            };
            Arc::new(map_on_own_pool(self.stages.len().div_ceil(band), tiles_of))
        })
        .clone()
    }

    /// Each row's mirror reads of a `width` x `height` map: the kept ones, those of `store`, or
    /// made now (and saved to `store`).
    pub(super) fn mirror_reads(
        &self,
        width: usize,
        height: usize,
        store: Option<&dyn PlanStore>,
    ) -> Arc<Vec<RowReads>> {
        let slot = recent_slot(&self.reads, (width, height), KEPT_SIZES);
        slot.get_or_init(|| {
            let name = format!("{} reads {width}x{height}", self.name);
            let texels = width.saturating_mul(height);
            let decode = |bytes: &[u8]| decode_reads(bytes, &self.stages, self.width(), texels);
            let make = || {
                let (w, rays) = (self.width(), self.rays());
                map_on_own_pool(rays.len(), |r| {
                    RowReads::new(&self.stages[r * w..(r + 1) * w], &rays[r], width, height)
                })
            };
            Arc::new(kept_in(store, &name, decode, make, |rows| encode_reads(rows)))
        })
        .clone()
    }
}

/// What a plan depends on: the mirror's material (its Fresnel weights are in the plan); the rough
/// materials' plans (hits and coverage) are the same for every rough material.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Key {
    mirror: Option<ProbeMaterial>,
    shape: ProbeShape,
    width: usize,
    height: usize,
    samples: usize,
}

static STORE: Recent<Key, Arc<Plan>> = Mutex::new(Vec::new());

/// The plan of `settings`' frame: the kept one, that of `store`, or made now (kept when small
/// enough, and saved to `store`).
pub(super) fn plan_for(settings: &ProbeSettings, store: Option<&dyn PlanStore>) -> Arc<Plan> {
    let mirror = settings.material.principled(settings.smith).is_mirror();
    let key = Key {
        mirror: mirror.then_some(settings.material),
        shape: settings.shape,
        width: settings.width,
        height: settings.height,
        samples: settings.samples,
    };
    let pixels = settings.width.saturating_mul(settings.height);
    let rays = if mirror { pixels.saturating_mul(settings.samples) } else { 0 };
    let bytes = pixels
        .saturating_mul(std::mem::size_of::<Stage>())
        .saturating_add(rays.saturating_mul(std::mem::size_of::<MirrorRay>()));
    let name = format!("probe sphere plan v1 {key:?}");
    if bytes > MAX_BYTES {
        return Arc::new(make(settings, name));
    }
    let slot = recent_slot(&STORE, key, KEPT);
    slot.get_or_init(|| {
        let decode =
            |bytes: &[u8]| decode_stages(bytes, pixels).map(|stages| with_stages(settings, name.clone(), stages));
        Arc::new(kept_in(store, &name, decode, || make(settings, name.clone()), |plan| encode_stages(&plan.stages)))
    })
    .clone()
}

/// `name`'s value in `store` when it is there and decodes; else `make`'s, saved to `store`.
fn kept_in<T>(
    store: Option<&dyn PlanStore>,
    name: &str,
    decode: impl FnOnce(&[u8]) -> Option<T>,
    make: impl FnOnce() -> T,
    encode: impl FnOnce(&T) -> Vec<u8>,
) -> T {
    if let Some(value) = store.and_then(|s| s.load(name)).and_then(|bytes| decode(&bytes)) {
        return value;
    }
    let value = make();
    if let Some(store) = store {
        store.save(name, encode(&value));
    }
    value
}

/// A plan of `settings` with its `stages` and no rays, reads, masks or tiles yet.
fn with_stages(settings: &ProbeSettings, name: String, stages: Vec<Stage>) -> Plan {
    Plan {
        settings: *settings,
        name,
        spans: spans(&stages, settings.width),
        stages,
        rays: OnceLock::new(),
        reads: Mutex::new(Vec::new()),
        fills: Mutex::new(Vec::new()),
        tiles: Mutex::new(Vec::new()),
    }
}

/// The plan of `settings`' frame, traced (see the module documentation).
fn make(settings: &ProbeSettings, name: String) -> Plan {
    let (stages, rays) = trace(settings);
    Plan { rays: OnceLock::from(rays), ..with_stages(settings, name, stages) }
}

/// Each row's span of `stages` (`width` a row) between its first and last stage that is not
/// empty; an empty range for a row of empty stages.
fn spans(stages: &[Stage], width: usize) -> Vec<Range<usize>> {
    let empty = |s: &Stage| matches!(s, Stage::Done(a) if *a == 0.0);
    stages
        .chunks(width.max(1))
        .map(|row| match row.iter().position(|s| !empty(s)) {
            Some(first) => first..row.len() - row.iter().rev().position(|s| !empty(s)).unwrap_or(0),
            None => 0..0,
        })
        .collect()
}

/// Every row of `settings`' frame traced: the pixels' stages and each row's mirror rays.
fn trace(settings: &ProbeSettings) -> (Vec<Stage>, Vec<Vec<MirrorRay>>) {
    let scene = scene(settings);
    let rows = map_on_own_pool(settings.height, |r| trace_row(&scene, r));
    let mut stages = Vec::with_capacity(settings.width * settings.height);
    let mut rays = Vec::with_capacity(rows.len());
    for (row, mut row_rays) in rows {
        stages.extend(row);
        row_rays.shrink_to_fit();
        rays.push(row_rays);
    }
    (stages, rays)
}

/// `f(i)` for every `i < n`, in order, run in parallel on a pool of its own ([`on_own_pool`]).
fn map_on_own_pool<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    on_own_pool(|parallel| if parallel { (0..n).into_par_iter().map(&f).collect() } else { (0..n).map(&f).collect() })
}

/// `work(true)` on a pool of as many threads as the caller's, from a thread that is no rayon
/// worker; `work(false)` on that thread when the system refuses the pool's threads.
fn on_own_pool<T: Send>(work: impl Fn(bool) -> T + Sync) -> T {
    let threads = rayon::current_num_threads();
    std::thread::scope(|s| {
        s.spawn(|| match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
            Ok(pool) => pool.install(|| work(true)),
            Err(_) => work(false),
        })
        .join()
        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// What the tests of [`super::plan_bytes`] need of plans: a store in memory, and one frame's plan
/// made and read back from it.
#[cfg(test)]
pub(super) mod tests_support {
    use std::collections::HashMap;

    use glam::DVec3;

    use super::super::Hit;
    use super::*;

    /// A [`PlanStore`] in memory.
    #[derive(Default)]
    pub(in super::super) struct MemoryStore(Mutex<HashMap<String, Vec<u8>>>);

    impl PlanStore for MemoryStore {
        fn load(&self, name: &str) -> Option<Vec<u8>> {
            self.0.lock().unwrap().get(name).cloned()
        }
        fn save(&self, name: &str, bytes: Vec<u8>) {
            self.0.lock().unwrap().insert(name.to_string(), bytes);
        }
    }

    #[test]
    fn a_rows_span_runs_from_its_first_to_its_last_stage_that_is_not_empty() {
        let hit = Hit { t: 1.0, point: DVec3::Z, normal: DVec3::Z, ng: DVec3::Z };
        let (empty, shade) = (Stage::Done(0.0), Stage::Shade(hit, DVec3::Z, 0.5));
        let mirror = Stage::Mirror { rays: 3, n: 4, coverage: 0.75 };
        // A black pixel partly covered (a ray hit nothing lit) is not empty either.
        let rows = [
            [empty, Stage::Done(0.25), empty, shade, empty],
            [empty; 5],
            [mirror, empty, empty, empty, mirror],
            [empty, empty, shade, empty, empty],
        ];
        let stages: Vec<Stage> = rows.concat();
        assert_eq!(spans(&stages, 5), [1..4, 0..0, 0..5, 2..3]);
    }

    /// A plan's stages and its reads of a 64 x 32 map (none for a rough frame).
    pub(in super::super) type Parts = (Vec<Stage>, Vec<RowReads>);

    /// The parts of `settings`' plan made here, and of a plan read back from a store it was
    /// saved to (its reads from rays traced again).
    pub(in super::super) fn made_and_read_back(settings: &ProbeSettings) -> (Parts, Parts) {
        let store = MemoryStore::default();
        let made = make(settings, "plan".into());
        store.save("plan", encode_stages(&made.stages));
        let stages = decode_stages(&store.load("plan").unwrap(), settings.width * settings.height).unwrap();
        let read = with_stages(settings, "plan".into(), stages);
        let mirror = settings.material.principled(settings.smith).is_mirror();
        let reads = |plan: &Plan| -> Vec<RowReads> {
            if !mirror {
                return Vec::new();
            }
            let rows = plan.mirror_reads(64, 32, None);
            rows.iter()
                .map(|r| RowReads { counts: r.counts.clone(), texel: r.texel.clone(), weight: r.weight.clone() })
                .collect()
        };
        let (made_reads, read_reads) = (reads(&made), reads(&read));
        ((made.stages, made_reads), (read.stages, read_reads))
    }
}
