//! `summary.md`: per map, the convergence slopes, the time each strategy needs to reach an
//! error, and the per-pixel sphere against Mitsuba.

use std::fmt::Write as _;

use super::stats;

use super::{seed_list, BenchConfig, BenchRow};

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
pub(super) fn per_pixel_against_mitsuba(s: &mut String, mine: &[&BenchRow]) {
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
