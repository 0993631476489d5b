//! The README's code excerpts are the sources' text: every fenced block that follows a line
//! `<!-- excerpt: PATH -->` must appear verbatim in PATH, so an excerpt cannot drift from the
//! code it shows (the failure prints the block to paste).

use std::path::Path;

fn excerpts(readme: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut lines = readme.lines().peekable();
    while let Some(line) = lines.next() {
        let Some(path) = line.trim().strip_prefix("<!-- excerpt:").and_then(|r| r.strip_suffix("-->")) else {
            continue;
        };
        let fence = lines.next().unwrap_or_default();
        assert!(fence.starts_with("```"), "the excerpt of {path} must be followed by a fenced block");
        let mut body = String::new();
        for l in lines.by_ref() {
            if l.starts_with("```") {
                break;
            }
            body.push_str(l);
            body.push('\n');
        }
        out.push((path.trim().to_string(), body));
    }
    out
}

#[test]
fn every_readme_excerpt_is_the_source_text() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let found = excerpts(&readme);
    assert!(!found.is_empty(), "the README has no excerpt markers: the 'Adding an operator' one was removed");
    for (path, body) in found {
        let source = std::fs::read_to_string(root.join(&path)).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert!(
            source.contains(&body),
            "the README's excerpt of {path} is not that file's text any more; the excerpt was:\n{body}"
        );
    }
}

#[test]
fn an_excerpt_that_drifted_is_caught() {
    let readme = "<!-- excerpt: x.rs -->\n```rust\nfn a() {}\n```\n";
    let found = excerpts(readme);
    assert_eq!(found, vec![("x.rs".to_string(), "fn a() {}\n".to_string())]);
    assert!(!"fn b() {}\n".contains(&found[0].1));
}

/// The files the README's shell commands name (`graphs/seed.ron`, `--set env.path=assets/...`),
/// from every ```sh block: each must be in the repository, so that the commands run on a fresh
/// clone with nothing beside it (nothing under `../shared`). Output paths (`--out`, `>`) are not
/// inputs and are left out.
fn command_inputs(readme: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_sh = false;
    for line in readme.lines() {
        if line.starts_with("```") {
            in_sh = line.trim() == "```sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        let code = line.split(" #").next().unwrap_or_default();
        let words: Vec<&str> = code.split_whitespace().collect();
        for (k, w) in words.iter().enumerate() {
            let prev = if k > 0 { words[k - 1] } else { "" };
            if matches!(prev, "--out" | ">" | "--report" | "--cache-dir" | "-o") {
                continue;
            }
            let value = w.rsplit('=').next().unwrap_or(w).trim_matches(|c| c == '"' || c == '\'');
            let known_ext = [".ron", ".hdr", ".exr", ".pfm", ".py", ".sh", ".txt", ".json"];
            if value.contains('/') && known_ext.iter().any(|e| value.ends_with(e)) && !value.contains('*') {
                out.push(value.to_string());
            }
        }
    }
    out
}

#[test]
fn every_file_a_readme_command_reads_ships_with_the_repository() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let inputs = command_inputs(&readme);
    assert!(inputs.iter().any(|p| p == "graphs/seed.ron"), "the main job's command is found: {inputs:?}");
    let missing: Vec<&String> =
        inputs.iter().filter(|p| p.starts_with("../") || p.starts_with('/') || !root.join(p).is_file()).collect();
    assert!(missing.is_empty(), "README commands read files a fresh clone does not have: {missing:?}");
}

#[test]
fn command_inputs_are_found_and_outputs_left_out() {
    let readme = "```sh\nhdrflow run graphs/a.ron --set e.path=../shared/x.hdr --out out/b.json  # c/d.ron\n```\n";
    assert_eq!(command_inputs(readme), vec!["graphs/a.ron".to_string(), "../shared/x.hdr".to_string()]);
}
