//! `hdrflow bench`: run time against error for every relighting strategy, beside the peers a
//! user would pick instead (NumPy, Mitsuba 3), plus the point targets.
//!
//! For each map: build its distribution and the exact reference sphere (`maths::render::reference`),
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

pub mod bake;
pub mod bake_error;
pub mod command;
pub mod glossy;
pub mod peak_memory;
pub mod stats;
pub mod targets;

mod one_pass;
mod peers;
mod results;
mod summary;
mod sweep;

use std::path::{Path, PathBuf};
use std::time::Instant;

use hdrflow::colour::rec709_luminance_f32;
use hdrflow::values::Image;
pub use results::replot;
pub use sweep::run;

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

/// A metric by name, NaN when absent.
fn metric(m: &hdrflow::values::Metrics, name: &str) -> f64 {
    m.get(name).unwrap_or(f64::NAN)
}

/// One measured point target (`targets`; `peak_memory` measures one of them).
#[derive(Clone, Debug)]
pub struct Target {
    pub name: String,
    pub measured: String,
    pub goal: String,
    pub met: Option<bool>,
}

/// Where the real map `file` is read from: the copy that ships in `assets/maps/` (the park, the
/// interior and the studio), else `data/file` (`--data`: Grace Cathedral's maps, beside the
/// repository), which may be missing.
pub fn map_path(data: &Path, file: &str) -> PathBuf {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/maps").join(file);
    if shipped.is_file() {
        shipped
    } else {
        data.join(file)
    }
}

/// Loads a map as the benchmark and `LoadHdr` see it.
pub fn load_map(spec: &MapSpec) -> Result<Image, String> {
    let mut img = if let Some(name) = spec.source.strip_prefix("builtin:") {
        hdrflow::formats::builtin::builtin(name).ok_or_else(|| format!("no built-in map {name:?}"))?
    } else {
        let bytes = std::fs::read(&spec.source).map_err(|e| format!("{}: {e}", spec.source))?;
        let ext = Path::new(&spec.source).extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
        hdrflow::formats::decode_by_extension(&bytes, &ext).map_err(|e| format!("{}: {}", spec.source, e))?
    };
    if spec.flip_vertical {
        img = img.flipped_vertical();
    }
    Ok(img)
}

/// Rec. 709 luminance of an RGB image, as `Luminance(weights: Rec709)` computes it.
pub fn luminance(img: &Image) -> Image {
    let data = (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| rec709_luminance_f32(img.rgb(x, y)))
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

/// The seeds of a sweep: `config.seed`, `config.seed + 1`, ... (`config.seeds` of them, at
/// least one).
pub fn seed_list(config: &BenchConfig) -> Vec<u64> {
    (0..config.seeds.max(1) as u64).map(|i| config.seed.wrapping_add(i)).collect()
}

#[cfg(test)]
mod tests {
    use super::results::{csv_of, read_csv};
    use super::summary::{expected_slope, slopes, time_to_reach};
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
