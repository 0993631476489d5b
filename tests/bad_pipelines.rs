//! Every file in `tests/bad/` is a broken pipeline that must be refused before anything runs.
//!
//! Each file starts with comment lines:
//!
//! ```text
//! // expect: <substring of stderr>      (one or more such lines)
//! // exit: <code>                        (2 for every pipeline-file error)
//! ```
//!
//! The test runs `hdrflow run tests/bad/NAME.ron` from the crate folder (so messages name the file
//! `tests/bad/NAME.ron`) with a private output and cache folder, and checks the exit code, every
//! expected substring, and that neither folder received a single file.

mod common;

use std::path::Path;

use common::{files_under, run_command, Sandbox, RUN_TIMEOUT};

/// One error kind per file; the list guards against a file being lost or renamed.
const EXPECTED_FILES: &[&str] = &[
    "channel_mismatch.ron",
    "cycle.ron",
    "duplicate_node.ron",
    "duplicate_output.ron",
    "every_phase_at_once.ron",
    "field_twice.ron",
    "fov_too_wide.ron",
    "independent_downstream_error.ron",
    "missing_field.ron",
    "missing_input_file.ron",
    "missing_node.ron",
    "octahedral_not_square.ron",
    "out_of_range.ron",
    "pixel_budget.ron",
    "save_absolute.ron",
    "save_bad_extension.ron",
    "save_chain_without_level.ron",
    "save_format_option_misplaced.ron",
    "save_ktx_format_not_ktx2.ron",
    "save_parent_dir.ron",
    "size_mismatch.ron",
    "syntax_error.ron",
    "unknown_field.ron",
    "unknown_field_alias.ron",
    "unknown_operator.ron",
    "unknown_port.ron",
    "wrong_kind.ron",
    "wrong_type.ron",
];

struct Expectation {
    substrings: Vec<String>,
    exit: i32,
}

fn expectation(path: &Path) -> Result<Expectation, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("reading {}: {e}", path.display()))?;
    let mut substrings = Vec::new();
    let mut exit = None;
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("// expect:") {
            let s = rest.trim();
            if s.is_empty() {
                return Err(format!("{}: empty `// expect:` line", path.display()));
            }
            substrings.push(s.to_string());
        } else if let Some(rest) = line.strip_prefix("// exit:") {
            exit =
                Some(rest.trim().parse::<i32>().map_err(|e| format!("{}: bad `// exit:` line: {e}", path.display()))?);
        }
    }
    if substrings.is_empty() {
        return Err(format!("{}: no `// expect:` line", path.display()));
    }
    let exit = exit.ok_or_else(|| format!("{}: no `// exit:` line", path.display()))?;
    Ok(Expectation { substrings, exit })
}

/// Runs `hdrflow run REL` with an empty output and cache folder of its own; returns the sandbox
/// (to inspect the folders), the report path and the output.
fn run_bad(rel: &str) -> (Sandbox, std::path::PathBuf, common::Output) {
    let sandbox = Sandbox::new();
    std::fs::create_dir_all(sandbox.out()).expect("out folder");
    std::fs::create_dir_all(sandbox.cache()).expect("cache folder");
    let report = sandbox.next_report();
    let cmd = sandbox.run_command(Path::new(rel), &sandbox.out(), &sandbox.cache(), &report, &[]);
    let output = run_command(cmd, RUN_TIMEOUT);
    (sandbox, report, output)
}

/// Runs one bad pipeline; returns a description of every way it failed the expectation.
fn check_one(name: &str) -> Vec<String> {
    let rel = format!("tests/bad/{name}");
    let expect = match expectation(&Path::new(common::MANIFEST_DIR).join(&rel)) {
        Ok(e) => e,
        Err(e) => return vec![e],
    };
    let (sandbox, report, output) = run_bad(&rel);

    let mut problems = Vec::new();
    if output.code != Some(expect.exit) {
        problems.push(format!("exit code {:?}, expected {}", output.code, expect.exit));
    }
    // The expected lines appear in the order written (errors are sorted by position).
    let mut from = 0;
    for s in &expect.substrings {
        match output.stderr[from..].find(s.as_str()) {
            Some(at) => from += at + s.len(),
            None if output.stderr.contains(s.as_str()) => {
                problems.push(format!("stderr has the expected substring out of order\n    expected: {s}"))
            }
            None => problems.push(format!("stderr does not contain the expected substring\n    expected: {s}")),
        }
    }
    if output.stderr.contains("panicked") {
        problems.push("stderr mentions a panic".to_string());
    }
    let out_files = files_under(&sandbox.out());
    if !out_files.is_empty() {
        problems.push(format!("files were written to the output folder: {out_files:?}"));
    }
    let cache_files = files_under(&sandbox.cache());
    if !cache_files.is_empty() {
        problems.push(format!("files were written to the cache folder: {cache_files:?}"));
    }
    if report.exists() {
        problems.push("a run report was written although nothing should have run".to_string());
    }
    if problems.is_empty() {
        Vec::new()
    } else {
        vec![format!("{rel}:\n  - {}\n{}", problems.join("\n  - "), output.describe())]
    }
}

#[test]
fn bad_folder_holds_one_file_per_error_kind() {
    let dir = Path::new(common::MANIFEST_DIR).join("tests/bad");
    let mut found: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ron"))
        .collect();
    found.sort();
    for name in EXPECTED_FILES {
        assert!(found.iter().any(|f| f == name), "tests/bad/{name} is missing (found: {found:?})");
    }
}

#[test]
fn every_bad_pipeline_is_refused_with_its_position_and_nothing_runs() {
    let dir = Path::new(common::MANIFEST_DIR).join("tests/bad");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ron"))
        .collect();
    names.sort();
    assert!(names.len() >= EXPECTED_FILES.len(), "only {} files in tests/bad: {names:?}", names.len());

    // All files are checked (in parallel: each one is a separate process) and every failure is
    // reported, not only the first.
    let failures: Vec<String> = std::thread::scope(|s| {
        let handles: Vec<_> = names.iter().map(|n| s.spawn(move || check_one(n))).collect();
        handles.into_iter().flat_map(|h| h.join().expect("checker thread")).collect()
    });
    assert!(
        failures.is_empty(),
        "{} of {} bad pipelines were not refused as expected:\n\n{}",
        failures.len(),
        names.len(),
        failures.join("\n\n")
    );
}

/// Validation reports every problem of a file at once, not just the first.
#[test]
fn all_problems_of_a_file_are_reported_together() {
    let sandbox = Sandbox::new();
    let graph = sandbox.write(
        "two_errors.ron",
        "(\n    nodes: {\n        \"env\": Constant(width: 0, height: 32),\n        \"exp\": Exposure(image: \"env\", stops: \"x\"),\n        \"save\": Save(input: \"exp\", path: \"exp.pfm\"),\n    },\n)\n",
    );
    let (output, _) = sandbox.run(&graph, &[]);
    output
        .assert_code(2)
        .assert_stderr_contains(":3:32: node \"env\": field \"width\": 0 is out of range")
        .assert_stderr_contains(":4:46: node \"exp\": field \"stops\": expected float")
        .assert_stderr_contains("2 errors in");
    assert!(files_under(&sandbox.out()).is_empty());
}

/// The book's page on pipeline files, which shows the errors of `tests/bad/`.
const PIPELINES_PAGE: &str = "docs/src/guides/pipelines.md";

/// The book's block of example errors (`docs/src/guides/pipelines.md`) is what the binary
/// prints for the `tests/bad/` files its marker names (`<!-- errors of tests/bad: a b c -->`,
/// then a fenced block): the first `error:` line of each, in the marker's order, so the page
/// cannot drift from the messages.
#[test]
fn the_books_error_block_is_what_the_binary_prints() {
    let page = std::fs::read_to_string(Path::new(common::MANIFEST_DIR).join(PIPELINES_PAGE)).expect(PIPELINES_PAGE);
    let mut lines = page.lines();
    let names: Vec<&str> = lines
        .by_ref()
        .find_map(|l| l.trim().strip_prefix("<!-- errors of tests/bad:").and_then(|r| r.strip_suffix("-->")))
        .expect("the pipelines page has no `<!-- errors of tests/bad: ... -->` marker")
        .split_whitespace()
        .collect();
    assert!(!names.is_empty(), "the pipelines page's error marker names no file");
    assert!(lines.next().is_some_and(|l| l.starts_with("```")), "the error marker must be followed by a fenced block");
    let written: Vec<&str> = lines.take_while(|l| !l.starts_with("```")).collect();
    let printed: Vec<String> = names
        .iter()
        .map(|name| {
            let rel = format!("tests/bad/{name}.ron");
            let (_, _, output) = run_bad(&rel);
            output
                .stderr
                .lines()
                .find(|l| l.starts_with("error:"))
                .unwrap_or_else(|| panic!("{rel} printed no error line:\n{}", output.describe()))
                .to_string()
        })
        .collect();
    assert!(
        written == printed,
        "the error block of {PIPELINES_PAGE} is not what the binary prints; paste this block instead:\n```text\n{}\n```",
        printed.join("\n")
    );
}
