//! The command line as a user meets it (issue 15): a summary line by default, the table with
//! `-v`, nothing with `-q`; small results printed; `--json`; the cache limit that never touches
//! another pipeline's entries; `cache stats|prune|clear`; `--jobs 0`; completions and man page.

mod common;

use common::{files_under, run_hdrflow, Sandbox};

const METRICS_GRAPH: &str = r#"(
    nodes: {
        "env":  LoadHdr(path: "builtin:constant"),
        "ref":  ReferenceSphere(env: "env", size: 16, albedo: 0.5),
        "sh":   ShSphere(env: "env", size: 16, albedo: 0.5),
        "err":  ImageError(image: "sh", reference: "ref"),
    },
)"#;

fn arg(p: &std::path::Path) -> String {
    p.display().to_string()
}

#[test]
fn the_seed_run_prints_one_summary_line_and_the_table_only_with_verbose() {
    let sb = Sandbox::new();
    let (out, cache) = (arg(&sb.out()), arg(&sb.cache()));
    let base = ["run", "graphs/seed.ron", "--out", &out, "--cache-dir", &cache];
    let cold = run_hdrflow(base);
    cold.assert_success();
    let lines: Vec<&str> = cold.stdout.lines().collect();
    assert_eq!(lines.len(), 1, "a default run prints one summary line:\n{}", cold.describe());
    assert!(lines[0].starts_with("68 nodes: 68 computed, 0 cached, 0 not needed;"), "{}", lines[0]);
    assert!(lines[0].contains("37 files written"), "{}", lines[0]);
    assert!(cold.stderr.trim().is_empty(), "off a terminal, no per-node lines without -v:\n{}", cold.stderr);

    let warm = run_hdrflow(base);
    assert_eq!(warm.stdout.lines().count(), 1, "{}", warm.describe());
    assert!(warm.stdout.contains("0 computed, 37 cached, 31 not needed"), "{}", warm.stdout);

    let verbose = run_hdrflow(base.iter().copied().chain(["-v"]));
    assert!(verbose.stdout.lines().count() > 68, "-v prints the per-node table:\n{}", verbose.stdout);
    assert!(verbose.stdout.contains("not needed"), "{}", verbose.stdout);

    let quiet = run_hdrflow(base.iter().copied().chain(["-q"]));
    quiet.assert_success();
    assert!(quiet.stdout.is_empty() && quiet.stderr.is_empty(), "{}", quiet.describe());
}

#[test]
fn a_metrics_target_prints_its_numbers_and_json_prints_the_report() {
    let sb = Sandbox::new();
    let graph = sb.write("m.ron", METRICS_GRAPH);
    let (g, out, cache) = (arg(&graph), arg(&sb.out()), arg(&sb.cache()));
    let run = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache]);
    run.assert_success();
    assert!(run.stdout.contains("err (metrics):"), "{}", run.stdout);
    let rmse_line = run.stdout.lines().find(|l| l.trim_start().starts_with("rmse ")).expect("an rmse line");
    let rmse: f64 = rmse_line.split_whitespace().nth(1).unwrap().parse().expect("a number");
    assert!(rmse.is_finite() && rmse < 0.01, "SH and the reference agree under a constant map: {rmse}");

    // --print shows any node; an image gets a one-line summary.
    let print = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--print", "ref"]);
    assert!(print.stdout.contains("ref: 16x16 image, channel means: R "), "{}", print.stdout);
    let bad = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--print", "rff"]);
    assert_eq!(bad.code, Some(2));
    assert!(bad.stderr.contains("did you mean \"ref\""), "{}", bad.stderr);

    let json = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--json", "--jobs", "0"]);
    json.assert_success();
    let report: serde_json::Value = serde_json::from_str(&json.stdout).expect("--json prints the report alone");
    let statuses: Vec<&str> =
        report["nodes"].as_array().unwrap().iter().map(|n| n["status"].as_str().unwrap()).collect();
    assert!(statuses.iter().all(|s| ["computed", "cached", "not needed"].contains(s)), "{statuses:?}");
    assert_eq!(report["nodes"][0]["ports"][0]["type"], "image");
}

#[test]
fn a_zero_cache_limit_leaves_another_pipelines_entries_alone() {
    let sb = Sandbox::new();
    let a = sb.write("a.ron", METRICS_GRAPH);
    let b = sb.write(
        "b.ron",
        r#"( nodes: { "c": Constant(width: 8, height: 4, color: 0.25), "s": Save(input: "c", path: "c.pfm") } )"#,
    );
    let (out, cache) = (arg(&sb.out()), arg(&sb.cache()));
    run_hdrflow(["run", &arg(&a), "--out", &out, "--cache-dir", &cache]).assert_success();
    let entries = |dir: &std::path::Path| {
        files_under(dir).into_iter().filter(|p| p.extension().is_some_and(|e| e == "val")).count()
    };
    let before = entries(&sb.cache());
    assert!(before >= 4, "pipeline a stored its results ({before})");
    let run_b = run_hdrflow(["run", &arg(&b), "--out", &out, "--cache-dir", &cache, "--cache-limit-mb", "0"]);
    run_b.assert_success();
    assert_eq!(run_b.stderr.matches("warning").count(), 1, "one warning for the limit:\n{}", run_b.stderr);
    assert_eq!(entries(&sb.cache()), before, "--cache-limit-mb 0 added nothing and removed nothing");
    let again = run_hdrflow(["run", &arg(&a), "--out", &out, "--cache-dir", &cache]);
    assert!(again.stdout.contains(" 0 computed"), "a's entries are still there:\n{}", again.stdout);

    let stats = run_hdrflow(["cache", "stats", "--cache-dir", &cache]);
    stats.assert_success();
    assert!(stats.stdout.contains(&format!("{before} entries")), "{}", stats.stdout);
    assert!(stats.stdout.contains("0 live runs"), "{}", stats.stdout);
    run_hdrflow(["cache", "prune", "--max-mb", "0", "--cache-dir", &cache]).assert_success();
    assert_eq!(entries(&sb.cache()), 0, "prune to 0 MiB with no live run removes everything");
    run_hdrflow(["run", &arg(&a), "--out", &out, "--cache-dir", &cache]).assert_success();
    let clear = run_hdrflow(["cache", "clear", "--cache-dir", &cache]);
    clear.assert_success();
    assert!(clear.stdout.contains(&format!("removed {before} of {before} entries")), "{}", clear.stdout);
}

#[test]
fn completions_and_the_manual_are_generated() {
    let bash = run_hdrflow(["completions", "bash"]);
    bash.assert_success();
    assert!(bash.stdout.contains("_hdrflow()") && bash.stdout.contains("--cache-limit-mb"), "{}", &bash.stdout[..200]);
    let man = run_hdrflow(["man"]);
    man.assert_success();
    assert!(man.stdout.starts_with(".ie") || man.stdout.contains(".TH hdrflow"), "{}", &man.stdout[..200]);
    // `-o FILE` writes the same text, creating the folders a fresh account does not have yet.
    let sb = Sandbox::new();
    let completions = sb.join("share/bash-completion/completions/hdrflow");
    run_hdrflow(["completions", "bash", "-o", &arg(&completions)]).assert_success();
    assert_eq!(std::fs::read_to_string(&completions).unwrap(), bash.stdout);
    let page = sb.join("share/man/man1/hdrflow.1");
    run_hdrflow(["man", "--output", &arg(&page)]).assert_success();
    assert_eq!(std::fs::read_to_string(&page).unwrap(), man.stdout);
}

/// `--print` and `--target` take `node.port`, the same form as fields (issue 25).
#[test]
fn print_and_target_take_node_dot_port() {
    let sb = Sandbox::new();
    let graph = sb.write("p.ron", r#"(nodes: { "env": LoadHdr(path: "builtin:sky"), "sun": SunExtract(env: "env") })"#);
    let (g, out, cache) = (arg(&graph), arg(&sb.out()), arg(&sb.cache()));
    let print = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--print", "sun.residual"]);
    print.assert_success();
    assert!(print.stdout.contains("sun.residual: 512x256 image"), "{}", print.stdout);
    let target = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--target", "sun.residual", "-v"]);
    target.assert_success();
    let bad = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--print", "sun.residul"]);
    assert_eq!(bad.code, Some(2), "{}", bad.describe());
    assert!(bad.stderr.contains("did you mean \"sun.residual\""), "{}", bad.stderr);
    let bad = run_hdrflow(["run", &g, "--out", &out, "--cache-dir", &cache, "--target", "sun.nope"]);
    assert_eq!(bad.code, Some(2), "{}", bad.describe());
    assert!(bad.stderr.contains("unknown target node \"sun.nope\""), "{}", bad.stderr);
}

/// Issue 25.8: `--out` naming a file is a usage error (exit 2) found before anything runs.
#[test]
fn out_naming_an_existing_file_is_a_usage_error() {
    let sb = Sandbox::new();
    let file = sb.write("not_a_folder", "x");
    let cache = arg(&sb.cache());
    let run = run_hdrflow(["run", "graphs/example.ron", "--out", &arg(&file), "--cache-dir", &cache]);
    run.assert_code(2).assert_stderr_contains("is a file; --out names the folder");
    assert!(files_under(&sb.cache()).is_empty(), "nothing ran: {:?}", files_under(&sb.cache()));
}

/// Issue 25.8: `plan`'s columns line up whatever the length of the node names.
#[test]
fn plan_columns_line_up_past_long_node_names() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "long.ron",
        r#"(
    nodes: {
        "a_node_name_well_past_twenty_four_characters": LoadHdr(path: "builtin:sky"),
        "b": Luminance(image: "a_node_name_well_past_twenty_four_characters"),
    },
)"#,
    );
    let plan = run_hdrflow(["plan", &arg(&graph), "--cache-dir", &arg(&sb.cache())]);
    plan.assert_success();
    let rows: Vec<&str> = plan.stdout.lines().take(3).collect();
    let column = |row: &str, word: &str| row.find(word).unwrap_or_else(|| panic!("{word} not in {row:?}"));
    let op = column(rows[0], "operator");
    assert_eq!(column(rows[1], "LoadHdr"), op, "{}", plan.stdout);
    assert_eq!(column(rows[2], "Luminance"), op, "{}", plan.stdout);
    let status = column(rows[0], "plan");
    assert_eq!(column(rows[1], "computed"), status, "{}", plan.stdout);
}

/// Issue 25.8: `--print` of a distribution says what a user wants to know about it.
#[test]
fn print_of_a_distribution_gives_its_size_total_and_brightest_texel() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "cdf.ron",
        r#"(
    nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "lum": Luminance(image: "env"),
        "cdf": BuildCdf(luminance: "lum"),
    },
)"#,
    );
    let run = run_hdrflow([
        "run",
        &arg(&graph),
        "--out",
        &arg(&sb.out()),
        "--cache-dir",
        &arg(&sb.cache()),
        "--print",
        "cdf",
    ]);
    run.assert_success();
    let line = run.stdout.lines().find(|l| l.starts_with("cdf: ")).unwrap_or_else(|| panic!("{}", run.describe()));
    for part in
        ["distribution over luminance x sin(theta)", "luminance integral ", "brightest texel (", "% of the samples"]
    {
        assert!(line.contains(part), "{part:?} not in {line}");
    }
}

/// Issue 25.5: a filled cache that cannot be written (here: its lease folder is a file, as
/// root ignores permission bits) is still read: the second run computes nothing, stores
/// nothing, and says once why.
#[test]
fn a_cache_that_cannot_be_written_is_still_read() {
    let sb = Sandbox::new();
    let graph = sb.write("metrics.ron", METRICS_GRAPH);
    let (out, cache) = (arg(&sb.out()), arg(&sb.cache()));
    let base = ["run", &arg(&graph), "--out", &out, "--cache-dir", &cache];
    run_hdrflow(base).assert_success();
    let live = sb.cache().join("v1/live");
    std::fs::remove_dir_all(&live).expect("the lease folder exists after a run");
    std::fs::write(&live, "not a folder").unwrap();
    let before = files_under(&sb.cache());
    let warm = run_hdrflow(base);
    warm.assert_success().assert_stderr_contains("reading the cache at").assert_stderr_contains("but storing nothing");
    assert!(warm.stdout.contains(" 0 computed,"), "every result came from the read-only cache:\n{}", warm.describe());
    assert_eq!(files_under(&sb.cache()), before, "nothing was stored");
}
