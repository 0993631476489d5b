//! `hdrflow bench --bake`: issue 24's bake benchmark (docs/src/benchmarks/bake.md, "Bake speed and error").
//!
//! For each map size (default 2048 x 1024 and 4096 x 2048: the shipped 1k park map through the
//! energy-preserving `Resize`, as no 2k or 4k map ships under a licence we may redistribute):
//!
//! 1. each preset baked as a user runs it, `hdrflow bake MAP --for ENGINE --no-cache -q` in a
//!    child process: its wall time and peak resident memory (`peak_memory::run_for_peak`);
//! 2. the Bevy preset's specular chain (a 256 cube, 9 levels, `Linear`), from the same source
//!    cube the bake filters (the map's `SunExtract` residual, as `--sun extract` gives it), with
//!    every estimator of `bake_error`: the error of each level against `exact: true` and the
//!    time of the whole chain, in one run, so that the ratios hold on a noisy machine.
//!
//! Writes `bake.md` into the output folder and prints it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use hdrflow::ibl_presets::PRESETS;
use hdrflow::maths::brdf::specular_lobe::RoughnessMap;
use hdrflow::maths::fit::sun::extract_sun;
use hdrflow::maths::resample::area_resize;
use hdrflow::maths::resample::latlong_cube::latlong_to_cube;
use hdrflow::maths::resample::layouts::LatLongSource;
use hdrflow::values::Image;

use super::bake_error::{chain_errors, Estimator};

/// What to run.
pub struct BakeBenchConfig {
    /// the map every size is made from
    pub source: PathBuf,
    /// lat-long widths (height = width / 2)
    pub widths: Vec<usize>,
    /// the estimators compared on the Bevy chain
    pub estimators: Vec<Estimator>,
    /// texels per level the exact reference is evaluated at
    pub texels_per_level: usize,
    /// skip the child-process bakes (errors only)
    pub errors_only: bool,
    /// the chain errors of the 4096 Khronos chain's sharp levels, scaled
    /// (`khronos_ratio_errors`), instead of the Bevy chain's
    pub khronos_ratios: bool,
    /// the presets baked (empty: all)
    pub presets: Vec<String>,
    pub out_dir: PathBuf,
}

/// The default estimators: hdrflow's counts, and the engines' tools' 1024 plain samples.
pub fn default_estimators() -> Vec<Estimator> {
    let mut e: Vec<Estimator> = [64, 256, 1024].into_iter().map(Estimator::Fis).collect();
    e.extend([Estimator::Default(256), Estimator::Default(1024), Estimator::Plain(1024)]);
    e
}

/// Runs the benchmark; the markdown report.
pub fn run(config: &BakeBenchConfig, log: &dyn Fn(&str)) -> Result<String, String> {
    let bytes = std::fs::read(&config.source).map_err(|e| format!("{}: {e}", config.source.display()))?;
    let ext = config.source.extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
    let original = hdrflow::formats::decode_by_extension(&bytes, &ext).map_err(|e| e.to_string())?;
    let work = std::env::temp_dir().join(format!("hdrflow-bench-bake-{}", std::process::id()));
    std::fs::create_dir_all(&work).map_err(|e| e.to_string())?;
    let mut md = String::from("# hdrflow bench --bake\n\n");
    let result = (|| {
        for &width in &config.widths {
            let map = area_resize::resize(&original, width, width / 2);
            let _ = writeln!(md, "## {width}x{} ({} resized)\n", width / 2, config.source.display());
            if !config.errors_only {
                let path = work.join(format!("park_{width}.pfm"));
                std::fs::write(&path, hdrflow::formats::pfm::encode(&map))
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                md.push_str(&preset_times(&path, (width * (width / 2) * 3 * 4) as f64, &config.presets, &work, log)?);
            }
            if config.khronos_ratios {
                md.push_str(&khronos_ratio_errors(&map, config, log));
            } else {
                md.push_str(&bevy_chain_errors(&map, config, log));
            }
        }
        Ok::<(), String>(())
    })();
    let _ = std::fs::remove_dir_all(&work);
    result?;
    std::fs::create_dir_all(&config.out_dir).map_err(|e| e.to_string())?;
    let path = config.out_dir.join("bake.md");
    hdrflow::engine::cache::store::write_atomic(&path, md.as_bytes())
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(md)
}

/// Each preset baked by the binary: wall seconds and peak resident memory, also as a multiple of
/// the map's float bytes (`map_bytes`: RGB f32, as `LoadHdr` hands the map over; the issue's
/// memory goal is 3x).
fn preset_times(
    map: &Path,
    map_bytes: f64,
    only: &[String],
    work: &Path,
    log: &dyn Fn(&str),
) -> Result<String, String> {
    let bin = super::peak_memory::hdrflow_binary()?;
    let mut md = String::from(
        "| preset | wall | peak RSS | peak / map floats | load average (1 min) before, after |\n|---|---|---|---|---|\n",
    );
    for preset in PRESETS.iter().filter(|p| only.is_empty() || only.iter().any(|o| o == p.name)) {
        let mut command = std::process::Command::new(&bin);
        command
            .arg("bake")
            .arg(map)
            .args(["--for", preset.name, "--no-cache", "-q", "--out"])
            .arg(work.join(out_folder(map, preset.name)));
        let load_before = load_average();
        let t0 = Instant::now();
        let (ok, peak) = super::peak_memory::run_for_peak(&mut command)?;
        let seconds = t0.elapsed().as_secs_f64();
        if !ok {
            return Err(format!("hdrflow bake {} --for {} failed", map.display(), preset.name));
        }
        let (mib, ratio) = (peak as f64 / 1048576.0, peak as f64 / map_bytes);
        let load = format!("{}, {}", load_before, load_average());
        log(&format!(
            "bake --for {}: {seconds:.2} s, peak {mib:.0} MiB ({ratio:.2}x the map's floats), load average {load}",
            preset.name
        ));
        let _ = writeln!(md, "| {} | {seconds:.2} s | {mib:.0} MiB | {ratio:.2}x | {load} |", preset.name);
    }
    md.push('\n');
    Ok(md)
}

/// The machine's one-minute load average (`/proc/loadavg`), so that a time measured while other
/// work ran says so; "n/a" where the file does not exist.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "n/a".into())
}

/// One output folder per map and preset: a glTF bake refuses a folder that holds another map's
/// asset, and the files of two sizes must not mix.
fn out_folder(map: &Path, preset: &str) -> String {
    let stem = map.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    format!("{stem}_{preset}")
}

/// The Bevy chain's error per level for every estimator, on the map's residual.
fn bevy_chain_errors(map: &Image, config: &BakeBenchConfig, log: &dyn Fn(&str)) -> String {
    let title = "Bevy chain (256 cube of the SunExtract residual, 9 levels, Linear)";
    chain_table(map, 256, 9, &config.estimators, config.texels_per_level, title, log)
}

/// The estimators compared on the Khronos chain's ratios: the per-texel reads (every level of
/// it before issue 36's groups), the default, and groups of 2 and 4 everywhere.
pub fn khronos_ratio_estimators() -> Vec<Estimator> {
    vec![Estimator::Fis(1024), Estimator::Default(1024), Estimator::Grouped(1024, 2), Estimator::Grouped(1024, 4)]
}

/// The sharp levels of a 16k map's Khronos chain (4096 cube, 13 levels, `Linear`) at a
/// sixteenth of the cost: a 1024 cube with 7 `Linear` levels has, at its levels 1-3, the
/// 4096 chain's ratios of the lobe (alpha) to its level's texels and to the pyramid's (alpha x
/// size 14.2, 28.4 and 32 at levels 1-3 of both; the filtered reads' levels follow alpha x the
/// top size), so the same group sizes and the same sampling errors.
pub fn khronos_ratio_errors(map: &Image, config: &BakeBenchConfig, log: &dyn Fn(&str)) -> String {
    let title = "The 4096 Khronos chain's sharp levels, scaled (1024 cube of the SunExtract residual, 7 levels, \
                 Linear: levels 1-3 have the ratios of the 4096 chain's levels 1-3)";
    chain_table(map, 1024, 7, &config.estimators, config.texels_per_level, title, log)
}

/// A chain's error per level for every estimator, on the map's residual resampled to a cube of
/// face `size`, `levels` levels, `Linear`.
fn chain_table(
    map: &Image,
    size: usize,
    levels: usize,
    estimators: &[Estimator],
    texels_per_level: usize,
    title: &str,
    log: &dyn Fn(&str),
) -> String {
    let residual = extract_sun(map, 8.0).residual;
    let t0 = Instant::now();
    let cube = latlong_to_cube(&LatLongSource::new(&residual), size);
    let resample = t0.elapsed().as_secs_f64();
    let roughness: Vec<f64> = (0..levels).map(|k| RoughnessMap::Linear.roughness(k, levels, &[])).collect();
    let (rows, reference) = chain_errors(&cube, &roughness, estimators, texels_per_level, log);
    let mut md = format!(
        "{title}: RMS relative error per level against `exact: true` ({texels_per_level} texels per level; \
         references {reference:.1} s; lat-long to cube {resample:.2} s)\n\n"
    );
    let _ = writeln!(
        md,
        "| estimator | chain time | {} |",
        (1..levels).map(|k| format!("{} ({}, r {:.3})", k, size >> k, roughness[k])).collect::<Vec<_>>().join(" | ")
    );
    let _ = writeln!(md, "|---|---|{}", "---|".repeat(levels - 1));
    for row in rows {
        let cells: Vec<String> = row.errors.iter().map(|e| format!("{e:.4}")).collect();
        let _ = writeln!(md, "| {} | {:.2} s | {} |", row.estimator.label(), row.seconds, cells.join(" | "));
    }
    md.push('\n');
    md
}
