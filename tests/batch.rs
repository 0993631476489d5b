//! `hdrflow batch` through the binary, on small PFM maps made here.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::*;

/// Six maps `maps/m0.pfm`..`m5.pfm` (`w` x `h`) and a pipeline over them.
fn library(sb: &Sandbox, w: usize, h: usize) -> PathBuf {
    for i in 0..6 {
        sb.write(format!("maps/m{i}.pfm"), common::small_pfm(w, h, 1.0 + i as f32));
    }
    sb.write("g.ron", common::batch_graph("maps/m0.pfm"))
}

/// `batch GRAPH --over env.path=MAPS/*.pfm --out OUT --cache-dir CACHE EXTRA...`.
fn batch_args(sb: &Sandbox, graph: &Path, out: &Path, extra: &[&str]) -> Vec<String> {
    let glob = format!("env.path={}/maps/*.pfm", sb.path().display());
    let mut args: Vec<String> = vec![
        "batch".into(),
        graph.display().to_string(),
        "--over".into(),
        glob,
        "--out".into(),
        out.display().to_string(),
        "--cache-dir".into(),
        sb.cache().display().to_string(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

fn batch(sb: &Sandbox, graph: &Path, out: &Path, extra: &[&str]) -> Output {
    run_hdrflow(batch_args(sb, graph, out, extra))
}

#[test]
fn plan_lists_the_cross_product_sorted_and_runs_nothing() {
    let sb = Sandbox::new();
    let g = library(&sb, 16, 8);
    let out = batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1", "--plan"]);
    out.assert_success();
    let lines: Vec<&str> = out.stdout.lines().filter(|l| l.contains("env.path=")).collect();
    assert_eq!(lines.len(), 12, "{}", out.describe());
    assert!(lines[0].contains("m0/stops=0") && lines[1].contains("m0/stops=1") && lines[11].contains("m5/stops=1"));
    assert!(!sb.out().exists(), "--plan ran nothing");
    // --zip pairs equal lengths and refuses unequal ones.
    let z = batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1,2,3,4,5", "--zip", "--plan"]);
    z.assert_success();
    assert!(z.stdout.contains("m5/stops=5") && z.stdout.contains("6 of 6 items"), "{}", z.describe());
    batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1", "--zip", "--plan"])
        .assert_code(2)
        .assert_stderr_contains("--zip");
    // A list instead of a glob, and the placeholders.
    let l = run_hdrflow([
        "batch",
        &g.display().to_string(),
        "--over",
        "e.stops=0,0.5,-1",
        "--out",
        &sb.out().display().to_string(),
        "--item-dir",
        "{index}-{e.stops}",
        "--plan",
    ]);
    l.assert_success();
    assert!(l.stdout.contains("0-0 ") && l.stdout.contains("1-0.5") && l.stdout.contains("2--1 "), "{}", l.describe());
}

#[test]
fn two_items_in_one_folder_or_a_bad_item_stop_everything_before_it_runs() {
    let sb = Sandbox::new();
    let g = library(&sb, 16, 8);
    batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1", "--item-dir", "{stem}"])
        .assert_code(2)
        .assert_stderr_contains("both map to folder");
    assert!(!sb.out().exists());
    let bad = batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,\"x\""]);
    bad.assert_code(2).assert_stderr_contains("nothing was run").assert_stderr_contains("m0/stops=x");
    assert!(!sb.out().exists());
}

#[test]
fn a_batch_shares_nodes_reports_metrics_and_resumes_from_the_cache() {
    let sb = Sandbox::new();
    let g = library(&sb, 16, 8);
    let report = sb.join("r.json");
    let r = report.display().to_string();
    let out = batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1", "--jobs", "2", "--report", &r]);
    out.assert_success();
    // 12 items x 9 nodes; `flat`, `soft`, `s3` once, `env` and `blur` once per map, the rest per
    // item: 3 + 12 + 12 x 4 = 63.
    assert!(out.stderr.contains("63 node evaluations for 108 items x nodes"), "{}", out.describe());
    // Shared: `flat`, `soft`, `s3`, and `env`, `blur` of each of the 6 maps; one number for the
    // first line and the summary (issue 25.6).
    assert!(out.stderr.contains("shared: 15 nodes used by several items"), "{}", out.describe());
    assert!(out.stderr.contains("(15 for nodes shared by several items)"), "{}", out.describe());
    assert!(out.stderr.contains("[12/12]"), "one line per item off a terminal: {}", out.describe());
    assert_eq!(
        files_under(&sb.out().join("m3/stops=1")),
        vec![PathBuf::from("e.pfm"), "m.json".into(), "soft.pfm".into()]
    );
    let rows: serde_json::Value = serde_json::from_slice(&read_file(&report)).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 12);
    assert!(rows.iter().all(|r| r["status"] == "computed"));
    assert_eq!(rows[1]["values"]["e.stops"], "1");
    assert!(rows[1]["metrics"]["diff.metrics.rmse"].as_f64().unwrap() > 0.0);
    let csv = String::from_utf8(read_file(&sb.out().join("batch.csv"))).unwrap();
    assert!(csv.starts_with("item,index,values,status,ms,error,diff.metrics."), "{csv}");
    assert_eq!(csv.lines().count(), 13);
    // Again: everything cached, same bytes.
    let before = batch_outputs(&sb.out());
    let again = batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1", "--report", &r]);
    again.assert_success();
    assert!(
        again.stderr.contains("0 computed, 12 cached") && again.stderr.contains("0 node evaluations"),
        "{}",
        again.describe()
    );
    assert_eq!(before, batch_outputs(&sb.out()));
}

/// A shared node inside the shared part that two items' shared nodes need (`soft` under each
/// map's `mix`) is computed once, not once per job: the summary's shared count is the first
/// line's, and the total is exactly the distinct keys (issue 25.6).
#[test]
fn a_shared_node_two_shared_jobs_need_is_computed_once() {
    let sb = Sandbox::new();
    for i in 0..2 {
        sb.write(format!("maps/m{i}.pfm"), common::small_pfm(16, 8, 1.0 + i as f32));
    }
    let g = sb.write(
        "g.ron",
        r#"( nodes: {
  "env":  LoadHdr(path: "maps/m0.pfm"),
  "flat": Constant(width: 16, height: 8, color: 0.25),
  "soft": Blur(image: "flat", sigma: 2),
  "mix":  Math(a: "env", b: "soft", op: Add),
  "e":    Exposure(image: "mix", stops: 0),
  "s1":   Save(input: "e", path: "e.pfm"),
} )"#,
    );
    let out = batch(&sb, &g, &sb.out(), &["--sweep", "e.stops=0,1,2", "--jobs", "1"]);
    out.assert_success();
    // Shared: flat, soft once; env, mix per map (2 x 2): 6. Per item: e, s1 (6 x 2 = 12).
    assert!(out.stderr.contains("shared: 6 nodes used by several items"), "{}", out.describe());
    assert!(out.stderr.contains("18 node evaluations for 36 items x nodes (6 for nodes shared"), "{}", out.describe());
}

#[test]
fn a_failing_item_is_named_and_stops_the_batch_unless_keep_going() {
    let sb = Sandbox::new();
    let g = library(&sb, 16, 8);
    // m1: a valid header with its pixels cut short.
    let mut broken = common::small_pfm(16, 8, 1.0);
    broken.truncate(broken.len() / 2);
    sb.write("maps/m1.pfm", broken);
    let stop = batch(&sb, &g, &sb.join("a"), &["--jobs", "1"]);
    stop.assert_code(1).assert_stderr_contains("item \"m1\" failed");
    assert!(stop.stderr.contains("4 not started"), "{}", stop.describe());
    // m0 is cached from the first batch.
    let all = batch(
        &sb,
        &g,
        &sb.join("b"),
        &["--jobs", "1", "--keep-going", "--report", &sb.join("r.json").display().to_string()],
    );
    all.assert_code(1).assert_stderr_contains("item \"m1\" failed");
    assert!(all.stderr.contains("4 computed, 1 cached, 1 failed"), "{}", all.describe());
    assert!(sb.join("b/m5/e.pfm").is_file());
    let csv = String::from_utf8(read_file(&sb.join("b/batch.csv"))).unwrap();
    assert!(csv.lines().any(|l| l.starts_with("m1,1,") && l.contains(",failed,")), "{csv}");
}

#[test]
fn a_killed_batch_resumes_to_the_same_bytes() {
    let sb = Sandbox::new();
    let g = library(&sb, 512, 256);
    let glob = format!("env.path={}/maps/*.pfm", sb.path().display());
    let args = |out: &Path, cache: &Path| -> Vec<String> {
        vec![
            "batch".into(),
            g.display().to_string(),
            "--over".into(),
            glob.clone(),
            "--sweep".into(),
            "e.stops=0,1".into(),
            "--jobs".into(),
            "1".into(),
            "--out".into(),
            out.display().to_string(),
            "--cache-dir".into(),
            cache.display().to_string(),
        ]
    };
    let reference = sb.join("reference");
    run_hdrflow(args(&reference, &sb.join("cache-ref"))).assert_success();
    let out = sb.join("killed");
    let mut child = hdrflow_command(args(&out, &sb.cache()))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !out.join("m0/stops=0/e.pfm").exists() && t0.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = child.kill();
    let status = child.wait().unwrap();
    let finished_before_kill = status.success();
    let again = run_hdrflow(args(&out, &sb.cache()));
    again.assert_success();
    if !finished_before_kill {
        assert!(!again.stderr.contains("0 computed, 12 cached"), "the kill left work to do: {}", again.describe());
    }
    assert_eq!(batch_outputs(&reference), batch_outputs(&out), "resumed outputs equal an uninterrupted batch");
}

#[test]
fn three_concurrent_shards_share_one_cache_and_one_folder() {
    let sb = Sandbox::new();
    let g = library(&sb, 64, 32);
    let glob = format!("env.path={}/maps/*.pfm", sb.path().display());
    let out = sb.out();
    let shard_args = |s: &str, plan: bool| -> Vec<String> {
        let mut v: Vec<String> = vec![
            "batch".into(),
            g.display().to_string(),
            "--over".into(),
            glob.clone(),
            "--sweep".into(),
            "e.stops=0,1".into(),
            "--out".into(),
            out.display().to_string(),
            "--cache-dir".into(),
            sb.cache().display().to_string(),
            "--shard".into(),
            s.into(),
            "--report".into(),
            sb.join(format!("r{}.json", &s[..1])).display().to_string(),
        ];
        if plan {
            v.push("--plan".into());
        }
        v
    };
    // Disjoint and covering: index mod 3.
    let mut seen = Vec::new();
    for i in 0..3 {
        let p = run_hdrflow(shard_args(&format!("{i}/3"), true));
        p.assert_success();
        for l in p.stdout.lines().filter(|l| l.contains("env.path=")) {
            let index: usize = l.split_whitespace().next().unwrap().parse().unwrap();
            assert_eq!(index % 3, i);
            seen.push(index);
        }
    }
    seen.sort();
    assert_eq!(seen, (0..12).collect::<Vec<_>>());
    run_hdrflow(["batch", &g.display().to_string(), "--over", &glob, "--out", "x", "--shard", "3/3", "--plan"])
        .assert_code(2);
    let running: Vec<_> = (0..3).map(|i| spawn(hdrflow_command(shard_args(&format!("{i}/3"), false)))).collect();
    for r in running {
        r.wait(RUN_TIMEOUT).assert_success();
    }
    for i in 0..3 {
        assert!(out.join(format!("batch.{i}-of-3.csv")).is_file());
    }
    let reference = sb.join("reference");
    let full = run_hdrflow([
        "batch",
        &g.display().to_string(),
        "--over",
        &glob,
        "--sweep",
        "e.stops=0,1",
        "--out",
        &reference.display().to_string(),
        "--cache-dir",
        &sb.join("cache-ref").display().to_string(),
    ]);
    full.assert_success();
    assert_eq!(batch_outputs(&reference), batch_outputs(&out));
}

/// Issue 25.6: Ctrl-C (SIGINT) stops a batch cleanly: no item starts after it, the running one
/// finishes, the report marks the rest "not started", one line says how many finished and how
/// to resume, and the exit code is 130.
#[cfg(unix)]
#[test]
fn ctrl_c_writes_the_report_and_says_how_to_resume() {
    let sb = Sandbox::new();
    let g = library(&sb, 512, 256);
    let out = sb.out();
    let report = sb.join("report.json");
    let r = report.display().to_string();
    let child = hdrflow_command(batch_args(&sb, &g, &out, &["--sweep", "e.stops=0,1", "--jobs", "1", "--report", &r]))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !out.join("m0/stops=0/e.pfm").exists() && t0.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(2));
    }
    let sent = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(sent.success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "stderr:\n{stderr}");
    let line = stderr.lines().find(|l| l.contains("items finished")).unwrap_or_else(|| panic!("{stderr}"));
    assert!(line.contains("run the same command again to resume"), "{line}");
    let finished: usize =
        line.split("interrupted: ").nth(1).and_then(|r| r.split(' ').next()).and_then(|n| n.parse().ok()).expect(line);
    assert!((1..12).contains(&finished), "{line}");
    let rows: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("the report is written")).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 12, "a row for every item");
    let not_started = rows.iter().filter(|r| r["status"] == "not started").count();
    assert_eq!(not_started, 12 - finished, "{rows:?}");
}
