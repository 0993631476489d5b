//! The rule for code hashes, shared with the build script (`build.rs` includes this file).

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
