//! The README's and the book's code excerpts are the sources' text, and their shell commands read
//! only files the repository ships. Every Markdown file checked is `README.md` and every page of
//! the book (`docs/src/**/*.md`):
//! - every fenced block that follows a line `<!-- excerpt: PATH -->` must appear verbatim in PATH,
//!   so an excerpt cannot drift from the code it shows (the failure prints the block to paste);
//! - every file a ```sh command reads must be in the repository, so that the commands run on a
//!   fresh clone with nothing beside it.

use std::path::{Path, PathBuf};

/// `README.md` and every page of the book, as (path relative to the crate, text), sorted.
fn documents() -> Vec<(String, String)> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths = vec![root.join("README.md")];
    walk(&root.join("docs/src"), &mut paths);
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p.strip_prefix(root).unwrap().display().to_string(), text)
        })
        .collect()
}

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
fn every_excerpt_of_the_readme_and_the_book_is_the_source_text() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = 0;
    for (doc, text) in documents() {
        for (path, body) in excerpts(&text) {
            found += 1;
            let source = std::fs::read_to_string(root.join(&path)).unwrap_or_else(|e| panic!("{doc}: {path}: {e}"));
            assert!(
                source.contains(&body),
                "{doc}'s excerpt of {path} is not that file's text any more; the excerpt was:\n{body}"
            );
        }
    }
    assert!(found > 0, "no excerpt markers in the README or the book: the 'Adding an operator' one was removed");
}

#[test]
fn an_excerpt_that_drifted_is_caught() {
    let readme = "<!-- excerpt: x.rs -->\n```rust\nfn a() {}\n```\n";
    let found = excerpts(readme);
    assert_eq!(found, vec![("x.rs".to_string(), "fn a() {}\n".to_string())]);
    assert!(!"fn b() {}\n".contains(&found[0].1));
}

/// The files the shell commands of a document name (`graphs/seed.ron`, `--set
/// env.path=assets/...`), from every ```sh block: each must be in the repository, so that the
/// commands run on a fresh clone with nothing beside it (nothing under `../shared`). Output paths
/// (`--out`, `>`, ...) are not inputs and are left out, and so is a file that an earlier command
/// of the same block wrote (that path, or one inside an output folder).
fn command_inputs(readme: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut written: Vec<String> = Vec::new();
    for line in readme.lines() {
        if line.starts_with("```") {
            in_sh = line.trim() == "```sh";
            written.clear();
            continue;
        }
        if !in_sh {
            continue;
        }
        let code = line.split(" #").next().unwrap_or_default();
        let words: Vec<&str> = code.split_whitespace().collect();
        for (k, w) in words.iter().enumerate() {
            let prev = if k > 0 { words[k - 1] } else { "" };
            let value = w.rsplit('=').next().unwrap_or(w).trim_matches(|c| c == '"' || c == '\'');
            if matches!(prev, "--out" | ">" | "--report" | "--cache-dir" | "-o") {
                written.push(value.trim_end_matches('/').to_string());
                continue;
            }
            if written.iter().any(|o| value == o || value.starts_with(&format!("{o}/"))) {
                continue;
            }
            let known_ext = [".ron", ".hdr", ".exr", ".pfm", ".py", ".sh", ".txt", ".json"];
            if value.contains('/') && known_ext.iter().any(|e| value.ends_with(e)) && !value.contains('*') {
                out.push(value.to_string());
            }
        }
    }
    out
}

#[test]
fn every_file_a_command_of_the_readme_or_the_book_reads_ships_with_the_repository() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut missing = Vec::new();
    for (doc, text) in documents() {
        let inputs = command_inputs(&text);
        if doc == "README.md" {
            assert!(inputs.iter().any(|p| p == "graphs/seed.ron"), "the README's main job is found: {inputs:?}");
        }
        for p in inputs {
            if p.starts_with("../") || p.starts_with('/') || !root.join(&p).is_file() {
                missing.push(format!("{doc}: {p}"));
            }
        }
    }
    assert!(missing.is_empty(), "commands read files a fresh clone does not have: {missing:#?}");
}

#[test]
fn command_inputs_are_found_and_outputs_left_out() {
    let readme = "```sh\nhdrflow run graphs/a.ron --set e.path=../shared/x.hdr --out out/b.json  # c/d.ron\n```\n";
    assert_eq!(command_inputs(readme), vec!["graphs/a.ron".to_string(), "../shared/x.hdr".to_string()]);
    // A file an earlier command of the block wrote is no input; the next block starts afresh.
    let made = "```sh\ncat > /tmp/m.ron\nhdrflow run /tmp/m.ron --out /tmp/maps\nhdrflow run g/s.ron --set e.path=/tmp/maps/x.pfm\n```\n\
                ```sh\nhdrflow run /tmp/m.ron\n```\n";
    assert_eq!(command_inputs(made), vec!["g/s.ron".to_string(), "/tmp/m.ron".to_string()]);
}

/// The client page that runs a JavaScript block of the book (the engines' loading code), by the
/// block's first import: the render page of that engine's test.
fn page_for(block: &str) -> Option<&'static str> {
    if block.contains("from '@babylonjs/core'") {
        Some("clients/babylon-web/render.js")
    } else if block.contains("from 'playcanvas'") {
        Some("clients/playcanvas-web/render.js")
    } else {
        None
    }
}

/// The lines of a book ```js block that a render page must hold: every code line, its trailing
/// `//` comment cut, except `const ...Url = '...'`, which names the user's file.
fn js_code_lines(block: &str) -> Vec<String> {
    block
        .lines()
        .map(|l| l.split("  //").next().unwrap_or_default().trim().to_string())
        .filter(|l| !l.is_empty() && !l.starts_with("//"))
        .filter(|l| !(l.starts_with("const ") && l.contains("Url = '")))
        .collect()
}

/// Every ```js block of the book (the engines' loading code in the baking guides) is code the render
/// tests run: each of its lines is a line of the engine's render page (tests/babylon_render.rs,
/// tests/gltf_render.rs and tests/playcanvas_render.rs load the bakes with those pages), so the
/// book cannot show loading code that no engine ran.
#[test]
fn every_javascript_block_of_the_book_is_a_render_pages_code() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut problems = Vec::new();
    let mut checked = 0;
    for (doc, text) in documents() {
        let mut block: Option<String> = None;
        for line in text.lines() {
            match (&mut block, line.trim_start()) {
                (None, "```js") => block = Some(String::new()),
                (Some(b), "```") => {
                    let Some(page) = page_for(b) else {
                        problems.push(format!("{doc}: a ```js block of no known engine:\n{b}"));
                        block = None;
                        continue;
                    };
                    let source = std::fs::read_to_string(root.join(page)).expect("the render page");
                    let page_lines: Vec<&str> = source.lines().map(str::trim).collect();
                    for l in js_code_lines(b) {
                        if !page_lines.contains(&l.as_str()) {
                            problems.push(format!("{doc}: not a line of {page}: {l}"));
                        }
                    }
                    checked += 1;
                    block = None;
                }
                (Some(b), _) => {
                    b.push_str(line);
                    b.push('\n');
                }
                (None, _) => {}
            }
        }
    }
    assert!(checked >= 3, "the baking guides' loading code was found ({checked} blocks)");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn a_javascript_line_no_page_runs_is_caught() {
    let lines = js_code_lines(
        "import { CubeTexture } from '@babylonjs/core';\nconst envUrl = 'a.env';\nscene.foo = 1;   // why\n// note\n",
    );
    assert_eq!(lines, ["import { CubeTexture } from '@babylonjs/core';", "scene.foo = 1;"]);
}
