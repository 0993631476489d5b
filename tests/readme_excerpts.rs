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
