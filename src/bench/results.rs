//! `results.csv` written and read back (`--replot`), and the log-log charts drawn from it.

use hdrflow::engine::cache::store::write_atomic;
use hdrflow::plotting::time_error::{self, Line};
use std::path::Path;

use super::summary::slopes;
use super::{BenchConfig, BenchRow};

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

pub(super) fn write_chart(config: &BenchConfig, map: &str, rows: &[BenchRow]) -> Result<(), String> {
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
pub(super) fn csv_of(rows: &[BenchRow]) -> String {
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
    hdrflow::formats::csv::text(std::iter::once(header.map(String::from).to_vec()).chain(records))
}

pub(super) fn write_csv(path: &Path, rows: &[BenchRow]) -> Result<(), String> {
    write_atomic(path, csv_of(rows).as_bytes()).map_err(|e| format!("{}: {e}", path.display()))
}
