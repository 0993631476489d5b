//! The peers a user would pick instead (NumPy, Mitsuba 3), run as Python processes on the same
//! maps and counts when their dependencies are present.

use hdrflow::engine::cache::store::write_atomic;
use hdrflow::maths::stats::error_metrics::image_error;
use hdrflow::values::Image;
use std::path::Path;

use super::{metric, seed_list, seeded_row, BenchConfig, BenchRow, MapSpec};

/// A peer's (strategy, count): the timed seed's milliseconds (NaN until seen) and every seed's
/// (relative RMSE, PSNR).
pub(super) type PeerGroup = (String, usize, f64, Vec<(f64, f64)>);

/// Runs the Python peers on the same map (written as PFM), reading back their images.
#[allow(clippy::too_many_arguments)]
pub(super) fn run_peers(
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
    write_atomic(&env_path, &hdrflow::formats::pfm::encode(env)).map_err(|e| e.to_string())?;
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
                .and_then(|b| hdrflow::formats::pfm::decode(&b).map_err(|e| e.to_string()))
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
