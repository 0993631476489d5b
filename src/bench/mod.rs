//! `hdrflow bench`: run time against error for every relighting strategy, beside the peers a
//! user would pick instead (NumPy, Mitsuba 3), plus the point targets.
//!
//! For each map: build its distribution and the exact reference sphere (`maths::reference`),
//! then for each sample count and strategy render the same sphere (same framing) and measure
//! its relative RMSE against the reference over the inner disc (pixel centres with
//! sx^2 + sy^2 <= 0.9: Mitsuba jitters its rays inside each pixel, so silhouette pixels would
//! measure coverage, not lighting).
//!
//! Seeds: every stochastic strategy (the shared sequences, whose seed is the scramble for Sobol
//! and Halton, the per-pixel strategies and the peers) is rendered with `seeds` independent
//! seeds, `seed`, `seed + 1`, ..., `seed + seeds - 1`; a point's error is the mean of the
//! per-seed relative RMSEs, with the half-width of its 95% confidence interval (Student t with
//! seeds - 1 degrees of freedom, `stats::mean_ci95`). Deterministic strategies (SH, the exact
//! reference) are rendered once (seeds = 1, CI 0). Timing does not depend on the seed: only the
//! first seed is timed (one warm-up run, then the median of `repeats`); the others are rendered
//! once, untimed. Per (map, strategy), the slope b of log(error) = a + b log(N) is fitted over
//! the counts (`stats::fit_slope`) to show the convergence rate.
//!
//! Writes `results.csv`, one log-log chart per map (`time_error_<map>.png` / `.svg`, error bars
//! = the 95% CI) and `summary.md` into the output folder.

pub mod glossy;
pub mod peak_memory;
pub mod stats;
pub mod targets;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::engine::cache::store::write_atomic;
use crate::geometry::latlong;
use crate::maths::error_metrics::image_error;
use crate::maths::glossy::Heuristic;
use crate::maths::per_pixel::{PerPixelRenderer, PerPixelSequence, PerPixelStrategy, PerPixelWarp};
use crate::maths::reference::reference_sphere;
use crate::maths::relight::{Estimator, SphereView};
use crate::maths::sequences::Sequence;
use crate::maths::sh;
use crate::ops::sampling::sample::draw;
use crate::ops::shading::relight_sphere::relight_shared;
use crate::plotting::time_error::{self, Line};
use crate::values::{Distribution2D, Image};

/// The largest per-pixel sample count swept with independent uniforms: past it a point takes
/// seconds per seed and shows nothing new (its slope is set by then).
pub const PER_PIXEL_MAX_SPP: usize = 1024;

/// The largest per-pixel sample count swept with Sobol points: Mitsuba's `ldsampler` reaches
/// errors at 1024 and 4096 spp that need more than 1024 spp here too, and "at equal error" needs
/// points on both sides of its error.
pub const PER_PIXEL_SOBOL_MAX_SPP: usize = 4096;

/// An environment to benchmark on.
#[derive(Clone, Debug)]
pub struct MapSpec {
    /// Short name for tables and file names.
    pub name: String,
    /// A file path or `builtin:NAME`.
    pub source: String,
    pub flip_vertical: bool,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    pub maps: Vec<MapSpec>,
    pub counts: Vec<usize>,
    pub size: usize,
    pub repeats: usize,
    pub albedo: f64,
    /// (theta, phi) in degrees.
    pub view: (f64, f64),
    /// The first seed; the sweep uses `seed..seed + seeds`.
    pub seed: u64,
    /// Independent seeds per stochastic point (at least 1): its error is their mean, with a
    /// 95% confidence interval when there are 2 or more.
    pub seeds: usize,
    pub out_dir: PathBuf,
    /// Folder with the peers' scripts (`numpy_seed.py`, `mitsuba_sphere.py`); None: no peers.
    pub peers_dir: Option<PathBuf>,
}

/// One measured point.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub map: String,
    pub strategy: String,
    /// `shared`, `per-pixel`, `sh`, `reference` or `peer`.
    pub family: String,
    pub count: usize,
    /// Warm median on the first seed.
    pub ms: f64,
    /// The mean over the seeds of the relative RMSE.
    pub relative_rmse: f64,
    /// The mean over the seeds of the PSNR (dB).
    pub psnr: f64,
    /// Half-width of the 95% confidence interval of `relative_rmse`: 0 for a deterministic
    /// strategy, NaN when unknown (one seed of a stochastic strategy, or an old results.csv).
    pub rmse_ci95: f64,
    /// Seeds averaged (1 for a deterministic strategy).
    pub seeds: usize,
}

impl BenchRow {
    /// SH orders and the exact reference: no randomness, one render.
    pub fn is_deterministic(&self) -> bool {
        self.family == "sh" || self.family == "reference"
    }

    /// The error as "mean ± ci95", "deterministic" or the single seed's value.
    pub fn error_text(&self) -> String {
        if self.is_deterministic() {
            format!("{:.4} (deterministic)", self.relative_rmse)
        } else if self.rmse_ci95.is_finite() {
            format!("{:.4} ± {:.4}", self.relative_rmse, self.rmse_ci95)
        } else {
            format!("{:.4} (1 seed)", self.relative_rmse)
        }
    }

    /// One line of progress output.
    pub fn describe(&self) -> String {
        let err = if self.is_deterministic() {
            format!("{:.5} (deterministic)", self.relative_rmse)
        } else {
            format!("{:.5} ± {:.5} ({} seeds)", self.relative_rmse, self.rmse_ci95, self.seeds)
        };
        format!("{:<12} {:<34} {:>5}  {:>9.2} ms  rel. RMSE {err}", self.map, self.strategy, self.count, self.ms)
    }
}

/// Loads a map as the benchmark and `LoadHdr` see it.
pub fn load_map(spec: &MapSpec) -> Result<Image, String> {
    let mut img = if let Some(name) = spec.source.strip_prefix("builtin:") {
        crate::formats::builtin::builtin(name).ok_or_else(|| format!("no built-in map {name:?}"))?
    } else {
        let bytes = std::fs::read(&spec.source).map_err(|e| format!("{}: {e}", spec.source))?;
        let ext = Path::new(&spec.source).extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
        crate::formats::decode_by_extension(&bytes, &ext).map_err(|e| format!("{}: {}", spec.source, e))?
    };
    if spec.flip_vertical {
        img = img.flipped_vertical();
    }
    Ok(img)
}

/// Rec. 709 luminance of an RGB image (the `Luminance` operator's weights).
pub fn luminance(img: &Image) -> Image {
    let data = (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            crate::ops::image::luminance::luminance(img.rgb(x, y), crate::ops::image::luminance::Weights::Rec709)
        })
        .collect();
    Image::from_vec(img.width, img.height, 1, data)
}

/// Runs `f` once to warm up, then `repeats` times; returns the median milliseconds and the
/// last result.
pub fn time_median<T>(repeats: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = f();
    let mut times = Vec::with_capacity(repeats.max(1));
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        out = f();
        times.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], out)
}

/// The inner-disc mask: pixel centres with sx^2 + sy^2 <= 0.9.
pub fn inner_disc_mask(size: usize) -> Vec<bool> {
    let mut mask = vec![false; size * size];
    for py in 0..size {
        for px in 0..size {
            let sx = 2.0 * (px as f64 + 0.5) / size as f64 - 1.0;
            let sy = 1.0 - 2.0 * (py as f64 + 0.5) / size as f64;
            mask[py * size + px] = sx * sx + sy * sy <= 0.9;
        }
    }
    mask
}

fn metric(m: &crate::values::Metrics, name: &str) -> f64 {
    m.get(name).unwrap_or(f64::NAN)
}

/// The seeds of a sweep: `config.seed`, `config.seed + 1`, ... (`config.seeds` of them, at
/// least one).
pub fn seed_list(config: &BenchConfig) -> Vec<u64> {
    (0..config.seeds.max(1) as u64).map(|i| config.seed.wrapping_add(i)).collect()
}

/// Renders with every seed: the first timed (one warm-up run, then the median of `repeats`),
/// the others once, untimed. Returns the median milliseconds and each seed's
/// (relative RMSE, PSNR) from `score`.
fn over_seeds(
    seeds: &[u64],
    repeats: usize,
    mut render: impl FnMut(u64) -> Result<Image, String>,
    score: impl Fn(&Image) -> (f64, f64),
) -> Result<(f64, Vec<(f64, f64)>), String> {
    let (ms, first) = time_median(repeats, || render(seeds[0]));
    let mut errors = vec![score(&first?)];
    for &seed in &seeds[1..] {
        errors.push(score(&render(seed)?));
    }
    Ok((ms, errors))
}

/// A row from per-seed (relative RMSE, PSNR) pairs: their means and the 95% CI of the error.
fn seeded_row(map: &str, strategy: String, family: &str, count: usize, ms: f64, errors: &[(f64, f64)]) -> BenchRow {
    let rmse: Vec<f64> = errors.iter().map(|e| e.0).collect();
    let (relative_rmse, rmse_ci95) = stats::mean_ci95(&rmse);
    let psnr = errors.iter().map(|e| e.1).sum::<f64>() / errors.len().max(1) as f64;
    BenchRow {
        map: map.to_string(),
        strategy,
        family: family.into(),
        count,
        ms,
        relative_rmse,
        psnr,
        rmse_ci95,
        seeds: errors.len(),
    }
}

/// Runs the whole sweep; `log` receives one line per measurement (for progress).
pub fn run(config: &BenchConfig, log: &dyn Fn(&str)) -> Result<Vec<BenchRow>, String> {
    std::fs::create_dir_all(&config.out_dir).map_err(|e| format!("{}: {e}", config.out_dir.display()))?;
    let mut rows = Vec::new();
    let albedo = [config.albedo; 3];
    let view_dir = latlong::direction_deg(config.view.0, config.view.1);
    let view = SphereView::new(config.size, view_dir);
    let mask = inner_disc_mask(config.size);
    let seeds = seed_list(config);
    for spec in &config.maps {
        let env = load_map(spec)?;
        let lum = luminance(&env);
        let dist = Distribution2D::build(&lum, true, true).map_err(|e| format!("{}: {e}", spec.name))?;
        log(&format!(
            "{}: {}x{} map; computing the exact reference ({}x{} sphere)",
            spec.name, env.width, env.height, config.size, config.size
        ));
        let t0 = Instant::now();
        let reference = reference_sphere(&env, &view, albedo);
        let ref_ms = t0.elapsed().as_secs_f64() * 1e3;
        rows.push(BenchRow {
            map: spec.name.clone(),
            strategy: "exact reference".into(),
            family: "reference".into(),
            count: env.width * env.height,
            ms: ref_ms,
            relative_rmse: 0.0,
            psnr: f64::INFINITY,
            rmse_ci95: 0.0,
            seeds: 1,
        });
        let score = |img: &Image| {
            let m = image_error(img, &reference, Some(&mask)).unwrap_or_default();
            (metric(&m, "relative_rmse"), metric(&m, "psnr"))
        };
        let push = |rows: &mut Vec<BenchRow>, row: BenchRow| {
            log(&row.describe());
            rows.push(row);
        };
        // Every strategy with independent uniforms; the two that matter with per-pixel
        // Owen-scrambled Sobol points too (Mitsuba's `ldsampler` is their peer); Mis with the
        // power heuristic, Mitsuba's `direct` integrator's, with both sequences; and with Sobol
        // points the hierarchical warp (Mitsuba's envmap sampler), which only changes results
        // with low-discrepancy points. Each configuration's records and tables are built once
        // per map and not timed, as Mitsuba's peer loads its scene once and times `mi.render`.
        let inversion = PerPixelWarp::Inversion;
        let balance = |s: PerPixelStrategy, q: PerPixelSequence| (s, q, Heuristic::Balance, inversion);
        let sobol = PerPixelSequence::Sobol;
        let configurations = PerPixelStrategy::ALL
            .map(|s| balance(s, PerPixelSequence::Random))
            .into_iter()
            .chain([PerPixelStrategy::Environment, PerPixelStrategy::Mis].map(|s| balance(s, sobol)))
            .chain(PerPixelSequence::ALL.map(|q| (PerPixelStrategy::Mis, q, Heuristic::Power, inversion)))
            .chain([
                (PerPixelStrategy::Environment, sobol, Heuristic::Balance, PerPixelWarp::Hierarchical),
                (PerPixelStrategy::Mis, sobol, Heuristic::Power, PerPixelWarp::Hierarchical),
            ]);
        let mut per_pixel = Vec::new();
        for (strategy, sequence, heuristic, warp) in configurations {
            let mut name = format!("per-pixel {}", strategy.name());
            if heuristic == Heuristic::Power {
                name.push_str(" Power");
            }
            if sequence == PerPixelSequence::Sobol {
                name.push_str(" Sobol");
            }
            if warp == PerPixelWarp::Hierarchical {
                name.push_str(" Hierarchical");
            }
            let prepared = Instant::now();
            let renderer = PerPixelRenderer::new(&env, &dist, strategy, sequence, warp);
            log(&format!(
                "{:<12} {name}: records and tables built in {:.2} ms (not timed below)",
                spec.name,
                prepared.elapsed().as_secs_f64() * 1e3
            ));
            let max_spp = match sequence {
                PerPixelSequence::Random => PER_PIXEL_MAX_SPP,
                PerPixelSequence::Sobol => PER_PIXEL_SOBOL_MAX_SPP,
            };
            per_pixel.push((name, max_spp, heuristic, renderer));
        }
        for &count in &config.counts {
            for seq in Sequence::ALL {
                let (ms, errors) = over_seeds(
                    &seeds,
                    config.repeats,
                    |seed| {
                        let set = draw(&dist, seq, count, seed);
                        relight_shared(&env, &set, config.size, albedo, view_dir, Estimator::Unbiased)
                            .map_err(|e| e.to_string())
                    },
                    score,
                )?;
                push(&mut rows, seeded_row(&spec.name, format!("shared {}", seq.name()), "shared", count, ms, &errors));
            }
            let (ms, errors) = over_seeds(
                &seeds,
                config.repeats,
                |seed| {
                    let set = draw(&dist, Sequence::Random, count, seed);
                    relight_shared(&env, &set, config.size, albedo, view_dir, Estimator::Seed)
                        .map_err(|e| e.to_string())
                },
                score,
            )?;
            push(
                &mut rows,
                seeded_row(&spec.name, "shared Random (seed's estimator)".into(), "shared", count, ms, &errors),
            );
            for (name, max_spp, heuristic, renderer) in &per_pixel {
                if count > *max_spp {
                    continue;
                }
                // Runs of a second or more need no more than one timed repeat.
                let repeats = if count >= 256 { 1 } else { config.repeats };
                let (ms, errors) = over_seeds(
                    &seeds,
                    repeats,
                    |seed| Ok(renderer.render(&view, albedo, *heuristic, count, seed)),
                    score,
                )?;
                push(&mut rows, seeded_row(&spec.name, name.clone(), "per-pixel", count, ms, &errors));
            }
        }
        for order in [2usize, 4] {
            let (ms, img) = time_median(config.repeats, || sh::sh_sphere(&env, &view, albedo, order));
            let mut row =
                seeded_row(&spec.name, format!("SH order {order}"), "sh", sh::sh_count(order), ms, &[score(&img)]);
            row.rmse_ci95 = 0.0;
            push(&mut rows, row);
        }
        if let Some(peers) = &config.peers_dir {
            run_peers(config, spec, &env, &reference, &mask, peers, &mut rows, log)?;
        }
        for (strategy, fit) in slopes(&rows, &spec.name) {
            log(&format!(
                "{:<12} {:<34} slope {:+.3} ± {:.3} over {} counts (expected {})",
                spec.name,
                strategy,
                fit.slope,
                fit.std_error,
                fit.points,
                expected_slope(&strategy)
            ));
        }
        write_chart(config, &spec.name, &rows)?;
    }
    write_csv(&config.out_dir.join("results.csv"), &rows)?;
    write_atomic(&config.out_dir.join("summary.md"), summary(config, &rows).as_bytes())
        .map_err(|e| format!("summary.md: {e}"))?;
    Ok(rows)
}

/// The fitted convergence slope of each stochastic strategy on `map`, over its mean errors
/// (strategies with fewer than 3 usable counts are left out), in the rows' order.
pub fn slopes(rows: &[BenchRow], map: &str) -> Vec<(String, stats::Slope)> {
    let mut points: Vec<(&str, Vec<(f64, f64)>)> = Vec::new();
    for r in rows.iter().filter(|r| r.map == map && !r.is_deterministic()) {
        match points.iter_mut().find(|(n, _)| *n == r.strategy) {
            Some((_, p)) => p.push((r.count as f64, r.relative_rmse)),
            None => points.push((r.strategy.as_str(), vec![(r.count as f64, r.relative_rmse)])),
        }
    }
    points.into_iter().filter_map(|(name, p)| stats::fit_slope(&p).map(|s| (name.to_string(), s))).collect()
}

/// The slope theory expects for a strategy, by its name: N^-1/2 for independent random
/// samples, faster for stratified and low-discrepancy ones; the seed's estimator is biased, so
/// its error levels off at the bias (slope towards 0).
pub fn expected_slope(strategy: &str) -> &'static str {
    let s = strategy.to_lowercase();
    if s.contains("seed's") {
        "towards 0 (biased: levels off at its bias)"
    } else if ["stratified", "sobol", "halton", "ldsampler"].iter().any(|k| s.contains(k)) {
        "faster than -0.5"
    } else {
        "-0.5"
    }
}

/// A peer's (strategy, count): the timed seed's milliseconds (NaN until seen) and every seed's
/// (relative RMSE, PSNR).
type PeerGroup = (String, usize, f64, Vec<(f64, f64)>);

/// Runs the Python peers on the same map (written as PFM), reading back their images.
#[allow(clippy::too_many_arguments)]
fn run_peers(
    config: &BenchConfig,
    spec: &MapSpec,
    env: &Image,
    reference: &Image,
    mask: &[bool],
    peers: &Path,
    rows: &mut Vec<BenchRow>,
    log: &dyn Fn(&str),
) -> Result<(), String> {
    let work = config.out_dir.join("peers").join(&spec.name);
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let env_path = work.join("env.pfm");
    write_atomic(&env_path, &crate::formats::pfm::encode(env)).map_err(|e| e.to_string())?;
    let counts: Vec<String> = config.counts.iter().map(|c| c.to_string()).collect();
    let seeds = seed_list(config).iter().map(|s| s.to_string()).collect::<Vec<_>>().join(",");
    for script in ["numpy_seed.py", "mitsuba_sphere.py"] {
        let path = peers.join(script);
        if !path.is_file() {
            log(&format!("SKIPPED peer {script}: {} not found", path.display()));
            continue;
        }
        let out = work.join(script.trim_end_matches(".py"));
        let status = std::process::Command::new("python3")
            .arg(&path)
            .arg("--env")
            .arg(&env_path)
            .args(["--size", &config.size.to_string(), "--counts", &counts.join(",")])
            .args(["--view", &format!("{},{}", config.view.0, config.view.1)])
            .args(["--albedo", &config.albedo.to_string(), "--seeds", &seeds])
            .args(["--repeats", &config.repeats.to_string()])
            .arg("--out-dir")
            .arg(&out)
            .status();
        match status {
            Ok(s) if s.success() => {}
            Ok(s) => {
                log(&format!("SKIPPED peer {script}: exited with {s} (are its dependencies installed? see bench/peers/README.md)"));
                continue;
            }
            Err(e) => {
                log(&format!("SKIPPED peer {script}: cannot run python3: {e}"));
                continue;
            }
        }
        let results: serde_json::Value = std::fs::read(out.join("results.json"))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .ok_or_else(|| format!("peer {script} wrote no readable results.json"))?;
        // One entry per (strategy, count, seed); `ms` is on the timed (first) seed's entry
        // (null on the others). Group by (strategy, count) in order of appearance.
        let mut groups: Vec<PeerGroup> = Vec::new();
        for r in results["results"].as_array().into_iter().flatten() {
            let (Some(strategy), Some(count), Some(image)) =
                (r["strategy"].as_str(), r["count"].as_u64(), r["image"].as_str())
            else {
                continue;
            };
            let img = std::fs::read(out.join(image))
                .map_err(|e| e.to_string())
                .and_then(|b| crate::formats::pfm::decode(&b).map_err(|e| e.to_string()))
                .map_err(|e| format!("peer {script} image {image}: {e}"))?;
            let m = image_error(&img, reference, Some(mask)).map_err(|e| format!("peer {script}: {e}"))?;
            let error = (metric(&m, "relative_rmse"), metric(&m, "psnr"));
            let count = count as usize;
            let ms = r["ms"].as_f64();
            match groups.iter_mut().find(|g| g.0 == strategy && g.1 == count) {
                Some(g) => {
                    g.3.push(error);
                    if g.2.is_nan() {
                        g.2 = ms.unwrap_or(f64::NAN);
                    }
                }
                None => groups.push((strategy.to_string(), count, ms.unwrap_or(f64::NAN), vec![error])),
            }
        }
        for (strategy, count, ms, errors) in groups {
            let row = seeded_row(&spec.name, strategy, "peer", count, ms, &errors);
            log(&row.describe());
            rows.push(row);
        }
        for s in results["skipped"].as_array().into_iter().flatten() {
            log(&format!("peer {script}: skipped {}", s));
        }
    }
    Ok(())
}

/// Redraws every map's chart from a `results.csv` written by `run` (into the same folder).
pub fn replot(config: &BenchConfig, csv_path: &Path) -> Result<usize, String> {
    let text = std::fs::read_to_string(csv_path).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let rows = read_csv(&text).map_err(|e| format!("{}:{e}", csv_path.display()))?;
    let mut maps: Vec<String> = rows.iter().map(|r| r.map.clone()).collect();
    maps.dedup();
    for map in &maps {
        write_chart(config, map, &rows)?;
    }
    Ok(maps.len())
}

/// Parses a `results.csv`: the current columns
/// `map,strategy,family,count,ms,relative_rmse,psnr,rmse_ci95,seeds`, or the older files
/// without the last two (read as one seed: CI 0 for deterministic rows, unknown (NaN) for the
/// others). The first line is the header; blank lines are skipped. Errors name the line.
pub fn read_csv(text: &str) -> Result<Vec<BenchRow>, String> {
    let mut rows = Vec::new();
    let mut reader = csv::ReaderBuilder::new().flexible(true).from_reader(text.as_bytes());
    for record in reader.records() {
        let record = record.map_err(|e| match e.position() {
            Some(p) => format!("{}: {e}", p.line()),
            None => e.to_string(),
        })?;
        let line = record.position().map_or(0, |p| p.line());
        if record.len() == 1 && record[0].trim().is_empty() {
            continue;
        }
        let c: Vec<&str> = record.iter().collect();
        let bad = || format!("{line}: expected map,strategy,family,count,ms,relative_rmse,psnr[,rmse_ci95,seeds]");
        if c.len() != 7 && c.len() != 9 {
            return Err(bad());
        }
        let mut row = BenchRow {
            map: c[0].into(),
            strategy: c[1].into(),
            family: c[2].into(),
            count: c[3].parse().map_err(|_| bad())?,
            ms: c[4].parse().map_err(|_| bad())?,
            relative_rmse: c[5].parse().map_err(|_| bad())?,
            psnr: c[6].parse().unwrap_or(f64::NAN),
            rmse_ci95: f64::NAN,
            seeds: 1,
        };
        if c.len() == 9 {
            row.rmse_ci95 = c[7].parse().map_err(|_| bad())?;
            row.seeds = c[8].parse().map_err(|_| bad())?;
        } else if row.is_deterministic() {
            row.rmse_ci95 = 0.0;
        }
        rows.push(row);
    }
    Ok(rows)
}

fn write_chart(config: &BenchConfig, map: &str, rows: &[BenchRow]) -> Result<(), String> {
    let mut lines: Vec<Line> = Vec::new();
    for r in rows.iter().filter(|r| r.map == map && r.family != "reference") {
        // Deterministic points have no bar; unknown CIs (old files, one seed) neither.
        let ci = if r.rmse_ci95.is_finite() { r.rmse_ci95 } else { 0.0 };
        match lines.iter_mut().find(|l| l.name == r.strategy) {
            Some(l) => {
                l.points.push((r.ms, r.relative_rmse));
                l.ci.push(ci);
            }
            None => lines.push(Line { name: r.strategy.clone(), points: vec![(r.ms, r.relative_rmse)], ci: vec![ci] }),
        }
    }
    for (strategy, fit) in slopes(rows, map) {
        if let Some(l) = lines.iter_mut().find(|l| l.name == strategy) {
            l.name = format!("{strategy} (slope {:.2})", fit.slope);
        }
    }
    let seeds = rows.iter().filter(|r| r.map == map).map(|r| r.seeds).max().unwrap_or(1);
    let errors = if seeds > 1 { format!("mean of {seeds} seeds ± 95% CI") } else { "one seed".to_string() };
    let title = format!("{map}: time against error, {}x{} sphere, 2 cores; {errors}", config.size, config.size);
    let png = time_error::plot_png(&title, &lines, 1000, 680)?;
    let svg = time_error::plot_svg(&title, &lines, 1000, 680)?;
    let stem = config.out_dir.join(format!("time_error_{map}"));
    write_atomic(&stem.with_extension("png"), &png).map_err(|e| e.to_string())?;
    write_atomic(&stem.with_extension("svg"), svg.as_bytes()).map_err(|e| e.to_string())?;
    Ok(())
}

/// The text of a `results.csv` (see [`read_csv`]; names quoted where RFC 4180 asks).
fn csv_of(rows: &[BenchRow]) -> String {
    let header = ["map", "strategy", "family", "count", "ms", "relative_rmse", "psnr", "rmse_ci95", "seeds"];
    let records = rows.iter().map(|r| {
        vec![
            r.map.clone(),
            r.strategy.clone(),
            r.family.clone(),
            r.count.to_string(),
            format!("{:.4}", r.ms),
            format!("{:.6e}", r.relative_rmse),
            format!("{:.3}", r.psnr),
            format!("{:.6e}", r.rmse_ci95),
            r.seeds.to_string(),
        ]
    });
    crate::values::csv::text(std::iter::once(header.map(String::from).to_vec()).chain(records))
}

fn write_csv(path: &Path, rows: &[BenchRow]) -> Result<(), String> {
    write_atomic(path, csv_of(rows).as_bytes()).map_err(|e| format!("{}: {e}", path.display()))
}

/// The time a strategy needs to reach `error`, interpolated log-log along its measured points
/// (None if it never gets there).
pub fn time_to_reach(points: &[(f64, f64)], error: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(first) = pts.first() {
        if first.1 <= error {
            return Some(first.0);
        }
    }
    for w in pts.windows(2) {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if e1 <= error && e0 > error {
            let f = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
            return Some((t0.ln() + f * (t1.ln() - t0.ln())).exp());
        }
    }
    None
}

/// A markdown summary: per map, each strategy's error and time at each count, and the
/// speed-up of the best hdrflow strategy over each peer at equal error.
pub fn summary(config: &BenchConfig, rows: &[BenchRow]) -> String {
    let mut s = String::new();
    let seeds = seed_list(config);
    let _ = writeln!(
        s,
        "Sphere {}x{}, albedo {}, view ({}, {}) deg; relative RMSE over the inner disc. Each error is the \
         mean over {} seed{} ({} to {}; scrambles for Sobol and Halton){}; deterministic strategies (SH) \
         are rendered once. Times: warm median of {} runs on the first seed.\n",
        config.size,
        config.size,
        config.albedo,
        config.view.0,
        config.view.1,
        seeds.len(),
        if seeds.len() == 1 { "" } else { "s" },
        seeds[0],
        seeds[seeds.len() - 1],
        if seeds.len() > 1 {
            " ± the half-width of its 95% confidence interval (Student t, seeds - 1 degrees of freedom)"
        } else {
            " (one seed: no confidence interval)"
        },
        config.repeats
    );
    let mut maps: Vec<&str> = rows.iter().map(|r| r.map.as_str()).collect();
    maps.dedup();
    for map in maps {
        let _ = writeln!(s, "### {map}\n");
        let mine: Vec<&BenchRow> = rows.iter().filter(|r| r.map == map).collect();
        if let Some(r) = mine.iter().find(|r| r.family == "reference") {
            let _ = writeln!(s, "Exact reference ({} texels): {:.0} ms.\n", r.count, r.ms);
        }
        let _ = writeln!(
            s,
            "| strategy | {} |",
            config.counts.iter().map(|c| format!("N = {c}")).collect::<Vec<_>>().join(" | ")
        );
        let _ = writeln!(s, "|---|{}", "---|".repeat(config.counts.len()));
        let mut strategies: Vec<&str> =
            mine.iter().filter(|r| r.family != "reference" && r.family != "sh").map(|r| r.strategy.as_str()).collect();
        strategies.dedup();
        let mut seen = Vec::new();
        for st in strategies {
            if seen.contains(&st) {
                continue;
            }
            seen.push(st);
            let cells: Vec<String> = config
                .counts
                .iter()
                .map(|&c| {
                    mine.iter()
                        .find(|r| r.strategy == st && r.count == c)
                        .map(|r| format!("{} ({:.1} ms)", r.error_text(), r.ms))
                        .unwrap_or_else(|| "-".into())
                })
                .collect();
            let _ = writeln!(s, "| {st} | {} |", cells.join(" | "));
        }
        for r in mine.iter().filter(|r| r.family == "sh") {
            let _ = writeln!(
                s,
                "\n{} ({} coefficients): relative RMSE {} in {:.1} ms.",
                r.strategy,
                r.count,
                r.error_text(),
                r.ms
            );
        }
        let fits = slopes(rows, map);
        if !fits.is_empty() {
            let _ = writeln!(
                s,
                "\nFitted convergence slopes: least squares of log(mean error) = a + b log(N) over the counts \
                 (N = samples, or samples per pixel).\n"
            );
            let _ = writeln!(s, "| strategy | slope b | ± std. error | expected | counts fitted |");
            let _ = writeln!(s, "|---|---|---|---|---|");
            for (st, fit) in &fits {
                let _ = writeln!(
                    s,
                    "| {st} | {:.3} | {:.3} | {} | {} |",
                    fit.slope,
                    fit.std_error,
                    expected_slope(st),
                    fit.points
                );
            }
        }
        // Equal-error comparison against each peer point.
        let ours: Vec<(&str, Vec<(f64, f64)>)> = {
            let mut v: Vec<(&str, Vec<(f64, f64)>)> = Vec::new();
            for r in mine.iter().filter(|r| r.family == "shared" || r.family == "per-pixel") {
                if r.strategy.contains("seed's") {
                    continue;
                }
                match v.iter_mut().find(|(n, _)| *n == r.strategy) {
                    Some((_, p)) => p.push((r.ms, r.relative_rmse)),
                    None => v.push((r.strategy.as_str(), vec![(r.ms, r.relative_rmse)])),
                }
            }
            v
        };
        let peers: Vec<&&BenchRow> = mine.iter().filter(|r| r.family == "peer").collect();
        if !peers.is_empty() {
            let _ = writeln!(
                s,
                "\n| peer point | its time | its mean error | best hdrflow strategy at that error | its time | speed-up |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|");
            for p in peers {
                let best = ours
                    .iter()
                    .filter_map(|(name, pts)| time_to_reach(pts, p.relative_rmse).map(|t| (*name, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                match best {
                    Some((name, t)) => {
                        let _ = writeln!(
                            s,
                            "| {} N={} | {:.1} ms | {} | {} | {:.2} ms | {:.0}x |",
                            p.strategy,
                            p.count,
                            p.ms,
                            p.error_text(),
                            name,
                            t,
                            p.ms / t
                        );
                    }
                    None => {
                        let _ = writeln!(
                            s,
                            "| {} N={} | {:.1} ms | {} | none reaches it in the sweep | - | - |",
                            p.strategy,
                            p.count,
                            p.ms,
                            p.error_text()
                        );
                    }
                }
            }
        }
        per_pixel_against_mitsuba(&mut s, &mine);
        let _ = writeln!(s, "\n![{map}](time_error_{map}.png)\n");
    }
    s
}

/// The per-pixel table of issue 14: each Mitsuba LLVM point beside `PerPixelSphere` with the
/// same estimator at the same spp (`Mis Power` with random uniforms for `independent`, `Mis
/// Power Sobol Hierarchical` for `ldsampler`: both draw one environment and one BSDF sample per
/// spp, combined with the power heuristic, the environment's through the same kind of warp)
/// and the fastest per-pixel strategy at Mitsuba's error.
fn per_pixel_against_mitsuba(s: &mut String, mine: &[&BenchRow]) {
    let mitsuba: Vec<&&BenchRow> = mine.iter().filter(|r| r.family == "peer" && r.strategy.contains("llvm")).collect();
    if mitsuba.is_empty() {
        return;
    }
    let mut per_pixel: Vec<(&str, Vec<(f64, f64)>)> = Vec::new();
    for r in mine.iter().filter(|r| r.family == "per-pixel") {
        match per_pixel.iter_mut().find(|(n, _)| *n == r.strategy) {
            Some((_, p)) => p.push((r.ms, r.relative_rmse)),
            None => per_pixel.push((r.strategy.as_str(), vec![(r.ms, r.relative_rmse)])),
        }
    }
    let _ = writeln!(
        s,
        "\nPer-pixel sampling against Mitsuba's LLVM variant (time ratio = Mitsuba / hdrflow; above 1 hdrflow is faster):\n"
    );
    let _ = writeln!(
        s,
        "| Mitsuba point | its time | its mean error | hdrflow at equal spp | its time | its mean error | time ratio | fastest hdrflow per-pixel at Mitsuba's error | its time | time ratio |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for p in mitsuba {
        // Mitsuba's envmap draws its texels by the hierarchical warp: with `ldsampler` (where
        // the warp matters) the same estimator is hdrflow's `Hierarchical` one.
        let twin = if p.strategy.contains("ldsampler") {
            "per-pixel Mis Power Sobol Hierarchical"
        } else {
            "per-pixel Mis Power"
        };
        let same = mine.iter().find(|r| r.strategy == twin && r.count == p.count);
        let (same_cells, same_ratio) = match same {
            Some(r) => (format!("{twin} | {:.1} ms | {}", r.ms, r.error_text()), format!("{:.2}x", p.ms / r.ms)),
            None => (format!("{twin} | - | -"), "-".into()),
        };
        let best = per_pixel
            .iter()
            .filter_map(|(name, pts)| time_to_reach(pts, p.relative_rmse).map(|t| (*name, t)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let best_cells = match best {
            Some((name, t)) => format!("{name} | {t:.1} ms | {:.2}x", p.ms / t),
            None => "none reaches it in the sweep | - | -".into(),
        };
        let _ = writeln!(
            s,
            "| {} N={} | {:.1} ms | {} | {same_cells} | {same_ratio} | {best_cells} |",
            p.strategy,
            p.count,
            p.ms,
            p.error_text()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields_with_commas_round_trip() {
        let row = |map: &str, strategy: &str| BenchRow {
            map: map.into(),
            strategy: strategy.into(),
            family: "shared".into(),
            count: 16,
            ms: 0.5,
            relative_rmse: 0.025,
            psnr: 30.0,
            rmse_ci95: 1.5e-3,
            seeds: 8,
        };
        let rows = [row("a, \"b\"", "plain"), row("sky", "line\nbreak")];
        let text = csv_of(&rows);
        assert!(text.contains("\"a, \"\"b\"\"\",plain,shared,16,0.5000,2.500000e-2,30.000,1.500000e-3,8\n"), "{text}");
        let back = read_csv(&text).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!((back[0].map.as_str(), back[0].strategy.as_str()), ("a, \"b\"", "plain"));
        assert_eq!((back[1].strategy.as_str(), back[1].seeds, back[1].rmse_ci95), ("line\nbreak", 8, 1.5e-3));
    }

    #[test]
    fn time_to_reach_interpolates_log_log() {
        let pts = [(1.0, 0.1), (100.0, 0.001)];
        assert!((time_to_reach(&pts, 0.01).unwrap() - 10.0).abs() < 1e-9);
        assert_eq!(time_to_reach(&pts, 0.5), Some(1.0));
        assert_eq!(time_to_reach(&pts, 1e-4), None);
    }

    #[test]
    fn a_tiny_sweep_runs_and_writes_its_files() {
        let dir = tempfile::tempdir().unwrap();
        let config = BenchConfig {
            maps: vec![MapSpec { name: "constant".into(), source: "builtin:constant".into(), flip_vertical: false }],
            counts: vec![16, 64, 256],
            size: 24,
            repeats: 1,
            albedo: 0.8,
            view: (90.0, 90.0),
            seed: 1,
            seeds: 4,
            out_dir: dir.path().into(),
            peers_dir: None,
        };
        let rows = run(&config, &|_| {}).unwrap();
        assert!(rows.iter().any(|r| r.strategy == "shared Sobol" && r.count == 64));
        // A constant map: low-discrepancy shared samples are close to exact with 64 samples.
        for r in
            rows.iter().filter(|r| (r.strategy == "shared Sobol" || r.strategy == "shared Stratified") && r.count == 64)
        {
            assert!(r.relative_rmse < 0.1, "{r:?}");
        }
        // The seed's estimator is biased: under grey light it is 1/sqrt(3) of the truth, an
        // error of at least 1 - 1/sqrt(3) = 0.42 whatever the sample noise adds.
        let seed = rows.iter().find(|r| r.strategy.contains("seed's") && r.count == 64).unwrap();
        assert!(seed.relative_rmse > 0.4, "{seed:?}");
        for f in ["results.csv", "summary.md", "time_error_constant.png", "time_error_constant.svg"] {
            assert!(dir.path().join(f).is_file(), "{f}");
        }
        // Four seeds: stochastic points are means with a confidence interval, SH is one
        // deterministic render.
        for r in rows.iter().filter(|r| r.strategy == "shared Random") {
            assert_eq!(r.seeds, 4, "{r:?}");
            assert!(r.rmse_ci95 > 0.0 && r.rmse_ci95 < r.relative_rmse, "{r:?}");
        }
        let per_pixel = rows.iter().find(|r| r.strategy == "per-pixel Environment" && r.count == 16).unwrap();
        assert!(per_pixel.seeds == 4 && per_pixel.rmse_ci95 > 0.0, "{per_pixel:?}");
        for r in rows.iter().filter(|r| r.family == "sh") {
            assert_eq!((r.seeds, r.rmse_ci95), (1, 0.0), "{r:?}");
            assert!(r.error_text().contains("deterministic"));
        }
        // Shared random samples converge as N^-1/2: the fitted slope is near -0.5.
        let fits = slopes(&rows, "constant");
        let random = fits.iter().find(|(s, _)| s == "shared Random").unwrap().1;
        assert!((-0.8..=-0.2).contains(&random.slope), "{random:?}");
        assert_eq!(random.points, 3);
        assert!(fits.iter().all(|(s, _)| !s.starts_with("SH")));
        let summary = std::fs::read_to_string(dir.path().join("summary.md")).unwrap();
        assert!(
            summary.contains("Fitted convergence slopes") && summary.contains("| shared Random | -0."),
            "{summary}"
        );
        assert!(summary.contains(" ± "), "{summary}");
        // results.csv reads back with the new columns.
        let back = read_csv(&std::fs::read_to_string(dir.path().join("results.csv")).unwrap()).unwrap();
        assert_eq!(back.len(), rows.len());
        for (a, b) in back.iter().zip(&rows) {
            assert_eq!((&a.strategy, a.count, a.seeds), (&b.strategy, b.count, b.seeds));
            assert!((a.rmse_ci95 - b.rmse_ci95).abs() <= 1e-6 * b.rmse_ci95.abs(), "{a:?} {b:?}");
        }
        // One seed: no interval for stochastic points.
        let one = BenchConfig { seeds: 1, counts: vec![16], out_dir: dir.path().join("one"), ..config };
        let rows = run(&one, &|_| {}).unwrap();
        let r = rows.iter().find(|r| r.strategy == "shared Random").unwrap();
        assert!(r.seeds == 1 && r.rmse_ci95.is_nan(), "{r:?}");
        assert!(r.error_text().contains("1 seed"));
    }

    #[test]
    fn old_results_csv_without_seed_columns_still_reads() {
        let old = "map,strategy,family,count,ms,relative_rmse,psnr\n\
                   sky,shared Sobol,shared,16,0.1000,2.5e-2,30.000\n\
                   sky,SH order 2,sh,9,2.0000,1.0e-2,40.000\n";
        let rows = read_csv(old).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].seeds, rows[0].relative_rmse), (1, 0.025));
        assert!(rows[0].rmse_ci95.is_nan());
        assert_eq!(rows[1].rmse_ci95, 0.0);
        let new = "map,strategy,family,count,ms,relative_rmse,psnr,rmse_ci95,seeds\n\
                   sky,\"shared Sobol, x\",shared,16,0.1000,2.5e-2,30.000,1.5e-3,8\n";
        let rows = read_csv(new).unwrap();
        assert_eq!((rows[0].strategy.as_str(), rows[0].seeds, rows[0].rmse_ci95), ("shared Sobol, x", 8, 1.5e-3));
        assert!(read_csv("h\nsky,a,shared,16,0.1,0.2,30,0.01\n").unwrap_err().starts_with("2:"));
    }

    #[test]
    fn expected_slopes_by_strategy() {
        assert_eq!(expected_slope("shared Random"), "-0.5");
        assert_eq!(expected_slope("per-pixel Mis"), "-0.5");
        assert_eq!(expected_slope("mitsuba llvm_ad_rgb direct independent"), "-0.5");
        assert_eq!(expected_slope("numpy shared random"), "-0.5");
        assert_eq!(expected_slope("shared Sobol"), "faster than -0.5");
        assert_eq!(expected_slope("mitsuba scalar_rgb direct ldsampler"), "faster than -0.5");
        assert!(expected_slope("shared Random (seed's estimator)").contains("biased"));
    }
}
