//! The rules for code hashes, shared with the build script (`build.rs` includes this file): the
//! normalised source a hash is taken of, and the files a source embeds, which the salt covers too
//! (`tests/cache_salt.rs` checks them with the same scan).

use std::path::{Component, Path, PathBuf};

/// Source text without line comments and blank space, so that comment and formatting edits
/// do not change a code hash.
pub fn normalise_source(source: &str) -> String {
    let mut out = String::with_capacity(source.len());
    for line in source.lines() {
        let t = line.trim();
        if t.is_empty() || t.starts_with("//") {
            continue;
        }
        for word in t.split_whitespace() {
            out.push_str(word);
            out.push(' ');
        }
        out.push('\n');
    }
    out
}

/// `path` with `.` and `..` resolved lexically.
pub fn lexical(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// The string literals of `args`, concatenated (`concat!("a", "b")` -> `ab`).
fn literals(args: &str) -> String {
    args.split('"').skip(1).step_by(2).collect()
}

/// The files `text` (normalised source of `file`) embeds with `include_bytes!`/`include_str!`:
/// a path after `env!("CARGO_MANIFEST_DIR")` is relative to the crate, any other to `file`'s
/// folder. Generated files (`OUT_DIR`) are this script's own output.
pub fn embedded(file: &Path, text: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for mac in ["include_bytes!(", "include_str!("] {
        for (at, _) in text.match_indices(mac) {
            let rest = &text[at + mac.len()..];
            let mut depth = 1;
            let end = rest
                .char_indices()
                .find(|&(_, c)| {
                    depth += i32::from(c == '(') - i32::from(c == ')');
                    depth == 0
                })
                .map_or(rest.len(), |(i, _)| i);
            let args = &rest[..end];
            if args.contains("OUT_DIR") {
                continue;
            }
            let path = match args.split_once("CARGO_MANIFEST_DIR") {
                // `after` starts with the variable name's closing quote.
                Some((_, after)) => PathBuf::from(literals(&after[1..]).trim_start_matches('/')),
                None => file.parent().unwrap_or(Path::new("")).join(literals(args)),
            };
            out.push(lexical(&path));
        }
    }
    out
}
