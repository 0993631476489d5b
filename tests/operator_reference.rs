//! The book's operator reference (`docs/src/reference/operators/`) is what `hdrflow ops
//! --markdown` writes: one page per operator and `index.md`, generated from the registry's specs.
//! A test compares the checked-in pages with the binary's, file by file, so the reference cannot
//! drift from the code (the failure prints the command that regenerates them). Also: an unknown
//! name given to `hdrflow ops` names the closest operators.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::run_hdrflow;

/// Where the pages are checked in, relative to the crate.
const PAGES: &str = "docs/src/reference/operators";
/// What a maintainer runs after changing an operator.
const REGENERATE: &str =
    "rm -r docs/src/reference/operators && cargo run --release -- ops --markdown docs/src/reference/operators";

/// Every `.md` file directly in `dir`, by name.
fn pages(dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            out.insert(name, std::fs::read_to_string(&path).unwrap());
        }
    }
    out
}

#[test]
fn the_checked_in_operator_pages_are_what_the_binary_writes() {
    let dir = tempfile::tempdir().unwrap();
    let written = dir.path().join("operators");
    let o = run_hdrflow(["ops", "--markdown", &written.display().to_string()]);
    o.assert_success();
    let fresh = pages(&written);
    assert!(fresh.contains_key("index.md") && fresh.contains_key("LoadHdr.md"), "{}", o.describe());
    let checked_in = pages(&Path::new(common::MANIFEST_DIR).join(PAGES));

    let missing: Vec<&String> = fresh.keys().filter(|k| !checked_in.contains_key(*k)).collect();
    let stale: Vec<&String> = checked_in.keys().filter(|k| !fresh.contains_key(*k)).collect();
    let differ: Vec<&String> = fresh.keys().filter(|k| checked_in.get(*k).is_some_and(|t| t != &fresh[*k])).collect();
    assert!(
        missing.is_empty() && stale.is_empty() && differ.is_empty(),
        "{PAGES} is not what `hdrflow ops --markdown` writes (missing: {missing:?}; no such operator any more: \
         {stale:?}; different: {differ:?}); regenerate it from the repository's root with:\n    {REGENERATE}"
    );
}

#[test]
fn each_page_gives_the_fields_ranges_defaults_and_ports() {
    let dir = tempfile::tempdir().unwrap();
    run_hdrflow(["ops", "--markdown", &dir.path().display().to_string()]).assert_success();
    let rotate = std::fs::read_to_string(dir.path().join("Rotate.md")).unwrap();
    for needle in [
        "# Rotate\n",
        "**Category**: [image](index.md#image)",
        "| `yaw` | float in [-3600, 3600] | 0.0 |",
        "## Output ports",
    ] {
        assert!(rotate.contains(needle), "Rotate.md lacks {needle:?}:\n{rotate}");
    }
    let index = std::fs::read_to_string(dir.path().join("index.md")).unwrap();
    assert!(index.contains("| [Rotate](Rotate.md) |"), "{index}");
    assert!(index.contains("## Value types"), "{index}");
    // A choice's options are escaped for the table; an input names the types it accepts.
    let lum = std::fs::read_to_string(dir.path().join("Luminance.md")).unwrap();
    assert!(lum.contains("Rec709 \\| Rec2020 \\| Mean \\| Max"), "{lum}");
    assert!(lum.contains("| `image` | input: image"), "{lum}");
    // An unbounded range says nothing and is left out.
    assert!(rotate.contains("| `matrix` | 9 floats | optional |"), "{rotate}");
}

#[test]
fn an_unknown_operator_name_suggests_the_closest() {
    run_hdrflow(["ops", "Rotat"])
        .assert_code(2)
        .assert_stderr_contains("no operator \"Rotat\"; did you mean \"Rotate\"");
    run_hdrflow(["ops", "--markdown", "x", "Rotate"]).assert_code(2);
}

/// The book's table of contents (`docs/src/SUMMARY.md`) lists every operator page, in the
/// index's order: mdBook renders only the pages it lists.
#[test]
fn the_book_lists_every_operator_page_in_the_index_order() {
    let root = Path::new(common::MANIFEST_DIR);
    let index = std::fs::read_to_string(root.join(PAGES).join("index.md")).unwrap();
    let in_index: Vec<String> = index
        .lines()
        .filter_map(|l| l.strip_prefix("| [")?.split_once("](").map(|(name, _)| name.to_string()))
        .collect();
    let summary = std::fs::read_to_string(root.join("docs/src/SUMMARY.md")).unwrap();
    let listed: Vec<String> = summary
        .lines()
        .filter_map(|l| l.trim().strip_prefix("- [")?.split_once("](reference/operators/"))
        .filter(|(_, rest)| *rest != "index.md)")
        .map(|(name, _)| name.to_string())
        .collect();
    let want: String = in_index.iter().map(|n| format!("    - [{n}](reference/operators/{n}.md)\n")).collect();
    assert!(
        !in_index.is_empty() && listed == in_index,
        "docs/src/SUMMARY.md must list the operator pages in the index's order; under \
         `- [Operator reference](reference/operators/index.md)` put:\n{want}"
    );
}
