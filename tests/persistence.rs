//! The cache's persistence policy (`--persist auto|all`) and a batch kept within
//! `--cache-limit-mb`, end to end.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::*;

/// Whether each node's results are in the cache after the run (the report's `stored`).
fn stored(r: &Report) -> BTreeMap<String, bool> {
    r.json["nodes"]
        .as_array()
        .expect("nodes")
        .iter()
        .map(|n| (n["name"].as_str().unwrap().to_string(), n["stored"].as_bool().expect("stored is a bool")))
        .collect()
}

fn cache_bytes(dir: &Path) -> u64 {
    files_under(&dir.join("v1"))
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "val"))
        .map(|p| std::fs::metadata(dir.join("v1").join(p)).unwrap().len())
        .sum()
}

/// A 2048x1024 constant (24 MiB), exposed, reduced to luminance (8 MiB) and saved; beside it a
/// small metrics node.
const CHEAP_CHAIN: &str = r#"( nodes: {
  "flat": Constant(width: 2048, height: 1024, color: (0.5, 0.25, 1.0)),
  "lit":  Exposure(image: "flat", stops: 1),
  "lum":  Luminance(image: "lit"),
  "tiny": Crop(image: "lum", x: 0, y: 0, width: 16, height: 8),
  "save": Save(input: "lum", path: "lum.pfm"),
  "save_tiny": Save(input: "tiny", path: "tiny.pfm"),
} )"#;

#[test]
fn auto_keeps_outputs_and_small_results_not_huge_cheap_intermediates() {
    let sb = Sandbox::new();
    let g = sb.write("g.ron", CHEAP_CHAIN);
    let (_, r) = sb.run_ok(&g, &[]);
    let s = stored(&r);
    assert!(!s["flat"], "{s:?}");
    assert!(!s["lit"], "{s:?}");
    assert!(!s["lum"], "{s:?}");
    assert!(s["tiny"], "a small result is kept: {s:?}");
    assert!(s["save"], "an output is kept: {s:?}");
    assert!(s["save_tiny"], "{s:?}");
    let auto_bytes = cache_bytes(&sb.cache());
    // The saved 8 MiB file and the small entries; none of the 24 MiB images.
    assert!(auto_bytes < 9 << 20, "{auto_bytes} bytes");

    // A rerun needs nothing recomputed: the outputs are cached.
    let (_, again) = sb.run_ok(&g, &[]);
    assert!(again.with_status("computed").is_empty(), "{:?}", again.status);
    assert!(stored(&again).values().filter(|s| **s).count() >= 2);

    // A new consumer of `lum` recomputes the cheap chain instead of reading 24 MiB back.
    let g2 = sb.write("g2.ron", CHEAP_CHAIN.replace("} )", "\"more\": Save(input: \"lit\", path: \"lit.pfm\"),\n} )"));
    let (_, r2) = sb.run_ok(&g2, &[]);
    assert_eq!(r2.status_of("flat"), "computed");
    assert_eq!(r2.status_of("lit"), "computed");
    assert_eq!(r2.status_of("save"), "cached");
    assert_eq!(r2.status_of("lum"), "not needed");
}

#[test]
fn persist_all_keeps_everything() {
    let sb = Sandbox::new();
    let g = sb.write("g.ron", CHEAP_CHAIN);
    let (_, r) = sb.run_ok(&g, &["--persist", "all"]);
    assert!(stored(&r).values().all(|s| *s), "{:?}", stored(&r));
    assert!(cache_bytes(&sb.cache()) > 40 << 20);
    let o = run_hdrflow(["run", g.to_str().unwrap(), "--persist", "some"]);
    o.assert_code(2).assert_stderr_contains("auto");
}

/// A library whose items share a large node: under a tight limit the shared entry must survive
/// until every item that loads it has run, while the folder stays within the limit.
fn shared_library(sb: &Sandbox) -> std::path::PathBuf {
    for i in 0..6 {
        sb.write(format!("maps/m{i}.pfm"), small_pfm(64, 32, 1.0 + i as f32));
    }
    // `big` does not depend on the map: one key for the whole batch, computed once, 6 MiB, and
    // every item consumes it (so it is pinned while items remain). Each item saves a 64x32
    // result and its metrics.
    sb.write(
        "g.ron",
        r#"( nodes: {
  "env":   LoadHdr(path: "unused.pfm"),
  "flat":  Constant(width: 1024, height: 512, color: (0.5, 0.5, 0.5)),
  "big":   Blur(image: "flat", sigma: 4),
  "up":    Resize(image: "env", width: 1024, height: 512),
  "mix":   Math(a: "up", b: "big", op: Add),
  "small": Resize(image: "mix", width: 64, height: 32),
  "diff":  Difference(a: "env", b: "small"),
  "s1":    Save(input: "diff", path: "diff.pfm"),
  "s2":    Save(input: "diff.metrics", path: "m.json"),
} )"#,
    )
}

#[test]
fn a_batch_stays_within_its_cache_limit_and_keeps_what_items_still_need() {
    let sb = Sandbox::new();
    let g = shared_library(&sb);
    let batch = |out: &str, cache: &str, extra: &[&str]| {
        let report = sb.join(format!("{out}.json"));
        let mut args: Vec<String> = [
            "batch",
            g.to_str().unwrap(),
            "--over",
            &format!("env.path={}/maps/*.pfm", sb.path().display()),
            "--out",
            sb.join(out).to_str().unwrap(),
            "--cache-dir",
            sb.join(cache).to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
            "--jobs",
            "2",
        ]
        .map(String::from)
        .into();
        args.extend(extra.iter().map(|s| s.to_string()));
        let o = run_hdrflow(&args);
        o.assert_success();
        let rows: serde_json::Value = serde_json::from_slice(&read_file(&report)).unwrap();
        (o, rows)
    };
    let (free, free_rows) = batch("free", "free-cache", &[]);
    // Limit: 3 MiB, below the shared 6 MiB entry alone.
    let (tight, tight_rows) = batch("tight", "tight-cache", &["--cache-limit-mb", "3"]);
    let evals = |rows: &serde_json::Value| -> Vec<u64> {
        rows.as_array().unwrap().iter().map(|r| r["evaluations"].as_u64().unwrap()).collect()
    };
    // The shared node ran once in both (items never recompute it), so every item did the same work.
    assert_eq!(evals(&tight_rows), evals(&free_rows), "{}\n{}", free.stderr, tight.stderr);
    assert!(tight.stderr.contains("shared by several items)"), "{}", tight.stderr);
    let shared = |o: &Output| o.stderr.rsplit_once('(').map(|(_, s)| s.to_string());
    assert_eq!(shared(&tight), shared(&free));
    // Once the last item has ended nothing is pinned: the folder is within the limit.
    assert!(cache_bytes(&sb.join("tight-cache")) <= 3 << 20, "{}", cache_bytes(&sb.join("tight-cache")));
    assert_eq!(batch_outputs(&sb.join("tight")), batch_outputs(&sb.join("free")));
}
