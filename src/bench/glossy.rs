//! `hdrflow bench --glossy`: run time against error of `GlossySphere`'s three strategies, and
//! what `SunExtract` buys, on each map.
//!
//! For each map and exponent: the exact reference (`reference_glossy_sphere` of the map), then
//! per spp and strategy (`Environment`, `Brdf`, `Mis` with the power and the balance heuristic)
//! the sphere's time (median of `repeats` after a warm-up) and relative RMSE over the inner disc
//! (as `hdrflow bench`). Then `SunExtract` (threshold 8 stops): `Mis` on the residual map (with
//! the residual's own distribution) plus the sun as a small-source light (`glossy::add_light`),
//! against the same reference, and the floor of that approximation (the residual's exact
//! sphere plus the light, no noise). Writes `glossy.csv` and `glossy.md` into the output folder.

use std::fmt::Write as _;

use crate::bench::{inner_disc_mask, load_map, luminance, time_median, MapSpec};
use hdrflow::engine::cache::store::write_atomic;
use hdrflow::geometry::latlong;
use hdrflow::maths::fit::sun::extract_sun;
use hdrflow::maths::render::glossy::{
    add_light, glossy_sphere, reference_glossy_sphere, GlossyBrdf, GlossyStrategy, Heuristic,
};
use hdrflow::maths::render::relight::SphereView;
use hdrflow::maths::stats::error_metrics::image_error;
use hdrflow::values::{Distribution2D, Image};

/// What to run.
#[derive(Clone, Debug)]
pub struct GlossyBenchConfig {
    pub maps: Vec<MapSpec>,
    pub spp: Vec<usize>,
    pub exponents: Vec<f64>,
    pub size: usize,
    pub repeats: usize,
    pub seed: u64,
    pub out_dir: std::path::PathBuf,
}

/// One measured point.
#[derive(Clone, Debug)]
pub struct GlossyRow {
    pub map: String,
    pub exponent: f64,
    pub strategy: String,
    pub spp: usize,
    pub ms: f64,
    pub relative_rmse: f64,
}

impl GlossyRow {
    pub fn describe(&self) -> String {
        format!(
            "{:<8} s {:>5} {:<30} {:>5} spp {:>9.2} ms  rel. RMSE {:.5}",
            self.map, self.exponent, self.strategy, self.spp, self.ms, self.relative_rmse
        )
    }
}

/// The BRDF measured: diffuse 0.2, specular 0.8 (the operators' defaults).
fn brdf(exponent: f64) -> GlossyBrdf {
    GlossyBrdf { diffuse: [0.2; 3], specular: [0.8; 3], exponent }
}

/// Runs the sweep; `log` receives one line per measurement.
pub fn run(config: &GlossyBenchConfig, log: &dyn Fn(&str)) -> Result<Vec<GlossyRow>, String> {
    std::fs::create_dir_all(&config.out_dir).map_err(|e| format!("{}: {e}", config.out_dir.display()))?;
    let view = SphereView::new(config.size, latlong::direction_deg(90.0, 90.0));
    let mask = inner_disc_mask(config.size);
    let mut rows = Vec::new();
    for spec in &config.maps {
        let env = load_map(spec)?;
        let dist = Distribution2D::build(&luminance(&env), true, true).map_err(|e| format!("{}: {e}", spec.name))?;
        let (sun_ms, sun) = time_median(config.repeats, || extract_sun(&env, 8.0));
        let residual_dist =
            Distribution2D::build(&luminance(&sun.residual), true, true).map_err(|e| format!("{}: {e}", spec.name))?;
        log(&format!(
            "{}: {}x{} map; SunExtract {:.1} ms: {} texels, {:.3e} sr",
            spec.name, env.width, env.height, sun_ms, sun.texels, sun.light.solid_angle
        ));
        for &s in &config.exponents {
            let b = brdf(s);
            let (ref_ms, reference) = time_median(1, || reference_glossy_sphere(&env, &view, &b));
            let error = |img: &Image| {
                image_error(img, &reference, Some(&mask)).ok().and_then(|m| m.get("relative_rmse")).unwrap_or(f64::NAN)
            };
            let mut push = |strategy: String, spp: usize, ms: f64, err: f64| {
                let row = GlossyRow { map: spec.name.clone(), exponent: s, strategy, spp, ms, relative_rmse: err };
                log(&row.describe());
                rows.push(row);
            };
            push("exact reference".into(), 0, ref_ms, 0.0);
            // The floor of the sun approximation: the residual's exact sphere plus the light.
            let mut floor = reference_glossy_sphere(&sun.residual, &view, &b);
            add_light(&mut floor, &view, &b, &sun.light);
            push("residual exact + sun (floor)".into(), 0, f64::NAN, error(&floor));
            for &spp in &config.spp {
                let repeats = if spp >= 256 { 1 } else { config.repeats };
                for (strategy, heuristic, name) in [
                    (GlossyStrategy::Environment, Heuristic::Power, "Environment"),
                    (GlossyStrategy::Brdf, Heuristic::Power, "Brdf"),
                    (GlossyStrategy::Mis, Heuristic::Power, "Mis Power"),
                    (GlossyStrategy::Mis, Heuristic::Balance, "Mis Balance"),
                ] {
                    let (ms, img) = time_median(repeats, || {
                        glossy_sphere(&env, &dist, &view, &b, strategy, heuristic, spp, config.seed)
                    });
                    push(name.into(), spp, ms, error(&img));
                }
                let (ms, img) = time_median(repeats, || {
                    let mut img = glossy_sphere(
                        &sun.residual,
                        &residual_dist,
                        &view,
                        &b,
                        GlossyStrategy::Mis,
                        Heuristic::Power,
                        spp,
                        config.seed,
                    );
                    add_light(&mut img, &view, &b, &sun.light);
                    img
                });
                push("Mis Power on residual + sun".into(), spp, ms, error(&img));
            }
        }
    }
    let header = ["map", "exponent", "strategy", "spp", "ms", "relative_rmse"].map(String::from);
    let records = rows.iter().map(|r| {
        [
            r.map.clone(),
            r.exponent.to_string(),
            r.strategy.clone(),
            r.spp.to_string(),
            format!("{:.3}", r.ms),
            format!("{:.6}", r.relative_rmse),
        ]
    });
    let csv = hdrflow::formats::csv::text(std::iter::once(header).chain(records));
    write_atomic(&config.out_dir.join("glossy.csv"), csv.as_bytes()).map_err(|e| format!("glossy.csv: {e}"))?;
    write_atomic(&config.out_dir.join("glossy.md"), markdown(config, &rows).as_bytes())
        .map_err(|e| format!("glossy.md: {e}"))?;
    Ok(rows)
}

/// One table per map: a row per (exponent, strategy), the relative RMSE and time per spp.
pub fn markdown(config: &GlossyBenchConfig, rows: &[GlossyRow]) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Glossy sphere {0}x{0} (diffuse 0.2, specular 0.8, view (90, 90)); relative RMSE over the inner disc against \
         ReferenceGlossySphere; time in ms (median of {1} after a warm-up; 1 run at 256 spp or more), {2} threads.\n",
        config.size,
        config.repeats,
        rayon::current_num_threads()
    );
    for spec in &config.maps {
        let _ = writeln!(md, "### {}\n", spec.name);
        let mut header = String::from("| s | strategy |");
        let mut rule = String::from("|---|---|");
        for spp in &config.spp {
            let _ = write!(header, " {spp} spp |");
            rule.push_str("---|");
        }
        let _ = writeln!(md, "{header}\n{rule}");
        for &s in &config.exponents {
            let of = |strategy: &'static str| {
                rows.iter().filter(move |r| r.map == spec.name && r.exponent == s && r.strategy == strategy)
            };
            if let Some(r) = of("exact reference").next() {
                let _ = writeln!(md, "| {s} | exact reference: {:.0} ms |{}", r.ms, " |".repeat(config.spp.len()));
            }
            if let Some(r) = of("residual exact + sun (floor)").next() {
                let _ = writeln!(
                    md,
                    "| {s} | residual exact + sun (floor): {:.4} |{}",
                    r.relative_rmse,
                    " |".repeat(config.spp.len())
                );
            }
            for strategy in ["Environment", "Brdf", "Mis Power", "Mis Balance", "Mis Power on residual + sun"] {
                let mut line = format!("| {s} | {strategy} |");
                for spp in &config.spp {
                    match of(strategy).find(|r| r.spp == *spp) {
                        Some(r) => {
                            let _ = write!(line, " {:.4} ({:.0} ms) |", r.relative_rmse, r.ms);
                        }
                        None => line.push_str(" |"),
                    }
                }
                let _ = writeln!(md, "{line}");
            }
        }
        md.push('\n');
    }
    md
}
