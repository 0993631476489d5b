//! The time-against-error sweep: every strategy at every sample count on every map, each
//! stochastic point over `seeds` seeds (see the module docs of `bench`).

use hdrflow::engine::cache::store::write_atomic;
use hdrflow::geometry::latlong;
use hdrflow::maths::ibl::sh;
use hdrflow::maths::render::glossy::Heuristic;
use hdrflow::maths::render::per_pixel::{PerPixelRenderer, PerPixelSequence, PerPixelStrategy, PerPixelWarp};
use hdrflow::maths::render::reference::reference_sphere;
use hdrflow::maths::render::relight::{Estimator, SphereView};
use hdrflow::maths::render::shared_relight::relight_sphere;
use hdrflow::maths::sampling::sequences::Sequence;
use hdrflow::maths::sampling::texel_samples;
use hdrflow::maths::stats::error_metrics::image_error;
use hdrflow::values::{Distribution2D, Image};
use std::time::Instant;

use super::peers::run_peers;
use super::results::{write_chart, write_csv};
use super::summary::{expected_slope, slopes, summary};
use super::{
    inner_disc_mask, load_map, luminance, metric, seed_list, seeded_row, time_median, BenchConfig, BenchRow,
    PER_PIXEL_MAX_SPP, PER_PIXEL_SOBOL_MAX_SPP,
};

/// Renders with every seed: the first timed (one warm-up run, then the median of `repeats`),
/// the others once, untimed. Returns the median milliseconds and each seed's
/// (relative RMSE, PSNR) from `score`.
pub(super) fn over_seeds(
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
                        let set = texel_samples::draw(&dist, seq, count, seed);
                        relight_sphere(&env, &set, config.size, albedo, view_dir, Estimator::Unbiased)
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
                    let set = texel_samples::draw(&dist, Sequence::Random, count, seed);
                    relight_sphere(&env, &set, config.size, albedo, view_dir, Estimator::Seed)
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
