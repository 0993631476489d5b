//! The worked evaluation example, `examples/evaluation/evaluate.ron`, run as its README runs it
//! (`hdrflow batch` over the three CC0 maps and the `blurred` and `turned` predictions): the files
//! of every map, `metrics.csv` equal to the saved JSON, the summary table, the truth's spheres
//! served from the cache for a second checkpoint, and the truths scored against themselves giving
//! 0 for every metric (the angle to 1e-5 degrees).

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use common::*;
use serde_json::Value as Json;

const GRAPH: &str = "examples/evaluation/evaluate.ron";
const MAPS: [&str; 3] = ["rooitou_park_1k", "st_fagans_interior_1k", "studio_small_03_1k"];
const SPHERES: [&str; 3] = ["mirror", "matte_silver", "diffuse"];
const METRICS: [&str; 4] = ["rmse", "si_rmse", "angular_error_deg", "norm_rmse"];
/// Six 960 x 540 spheres per map on a shared 2-core machine.
const TIMEOUT: Duration = Duration::from_secs(1200);

/// The README's command for the predictions matching `pred_glob`, into `out`.
fn evaluate(sb: &Sandbox, pred_glob: &str, out: &Path) -> Output {
    let args = [
        "batch",
        GRAPH,
        "--over",
        "gt.path=assets/maps/*.hdr",
        "--over",
        &format!("pred.path={pred_glob}"),
        "--zip",
        "--item-dir",
        "{stem}",
        "--out",
        &out.display().to_string(),
        "--report",
        &out.join("batch.json").display().to_string(),
        "--cache-dir",
        &sb.cache().display().to_string(),
    ];
    let out = run_command(hdrflow_command(args), TIMEOUT);
    out.assert_success();
    out
}

fn json(path: &Path) -> Json {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A `metrics.csv` row: (item, node) and the row's numbers by column name.
type MetricsRow = ((String, String), Vec<(String, f64)>);

/// `metrics.csv`'s rows.
fn metrics_csv(path: &Path) -> Vec<MetricsRow> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    assert_eq!(header[..3], ["item", "index", "node"], "{}", path.display());
    lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            let numbers =
                header[3..].iter().zip(&cells[3..]).map(|(h, c)| (h.to_string(), c.parse().unwrap())).collect();
            ((cells[0].to_string(), cells[2].to_string()), numbers)
        })
        .collect()
}

fn check_checkpoint(out: &Path, stdout: &str) {
    let rows = metrics_csv(&out.join("metrics.csv"));
    assert_eq!(rows.len(), MAPS.len() * SPHERES.len(), "one row per map and sphere");
    for map in MAPS {
        for sphere in SPHERES {
            let saved = json(&out.join(map).join(format!("{sphere}.json")));
            let (_, row) = rows
                .iter()
                .find(|((item, node), _)| item == map && node == sphere)
                .unwrap_or_else(|| panic!("no metrics.csv row for {map}, {sphere}"));
            for m in METRICS {
                let v = saved[m].as_f64().unwrap_or_else(|| panic!("{map}/{sphere}.json has no {m}"));
                assert!(v.is_finite() && v > 0.0, "{map}/{sphere}.json: {m} = {v}");
                let in_csv = row.iter().find(|(h, _)| h == m).map(|(_, x)| *x);
                assert_eq!(in_csv, Some(v), "{map}, {sphere}: metrics.csv's {m} is not the JSON's");
            }
            let sphere_exr = out.join(map).join(format!("{sphere}.exr"));
            assert!(sphere_exr.is_file(), "{} missing", sphere_exr.display());
        }
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.starts_with("| | items | rmse | si_rmse | angular_error_deg | norm_rmse |"), "{summary}");
    for sphere in SPHERES {
        let line = summary.lines().find(|l| l.starts_with(&format!("| {sphere} | 3 |")));
        let line = line.unwrap_or_else(|| panic!("summary.md has no row for {sphere} over 3 maps:\n{summary}"));
        assert!(line.contains(" ± "), "{line}: no interval");
    }
    assert!(stdout.contains(&summary), "the command prints the summary table:\n{stdout}");
    let summary_csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert!(summary_csv.starts_with("node,field,n,nonfinite,mean,ci95_low,ci95_high\n"), "{summary_csv}");
}

#[test]
fn the_example_scores_two_checkpoints_and_the_truths_score_zero() {
    let sb = Sandbox::new();
    let out = |c: &str| -> PathBuf { sb.out().join(c) };

    let blurred = evaluate(&sb, "examples/evaluation/predictions/blurred/*.hdr", &out("blurred"));
    check_checkpoint(&out("blurred"), &blurred.stdout);

    // A second checkpoint finds the truth's spheres in the cache: one map run on its own shows it.
    let report = sb.join("turned_park.json");
    let args = [
        "run",
        GRAPH,
        "--set",
        "gt.path=\"assets/maps/rooitou_park_1k.hdr\"",
        "--set",
        "pred.path=\"examples/evaluation/predictions/turned/rooitou_park_1k.hdr\"",
        "--out",
        &sb.join("turned_park").display().to_string(),
        "--cache-dir",
        &sb.cache().display().to_string(),
        "--report",
        &report.display().to_string(),
        "--quiet",
    ];
    run_command(hdrflow_command(args), TIMEOUT).assert_success();
    let report = read_report(&report);
    for sphere in SPHERES {
        assert_eq!(report.status_of(&format!("gt_{sphere}")), "cached", "the truth's {sphere} sphere");
        assert_eq!(report.status_of(&format!("pred_{sphere}")), "computed", "the prediction's {sphere} sphere");
    }
    let turned = evaluate(&sb, "examples/evaluation/predictions/turned/*.hdr", &out("turned"));
    check_checkpoint(&out("turned"), &turned.stdout);

    // The truths against themselves: the same spheres (the same cache keys), every metric 0 but
    // the angle: the arccos of a dot product rounded just below 1 leaves about 2e-7 degrees.
    let args = [
        "batch",
        GRAPH,
        "--over",
        "gt.path=assets/maps/*.hdr",
        "--over",
        "pred.path=assets/maps/*.hdr",
        "--zip",
        "--item-dir",
        "{stem}",
        "--out",
        &out("truth").display().to_string(),
        "--report",
        &out("truth").join("batch.json").display().to_string(),
        "--cache-dir",
        &sb.cache().display().to_string(),
    ];
    run_command(hdrflow_command(args), TIMEOUT).assert_success();
    for ((item, node), row) in metrics_csv(&out("truth").join("metrics.csv")) {
        for (m, v) in row.iter().filter(|(h, _)| METRICS.contains(&h.as_str())) {
            let bound = if m == "angular_error_deg" { 1e-5 } else { 0.0 };
            assert!(*v <= bound, "{item}, {node}: {m} of a truth against itself is {v}");
        }
    }
}
