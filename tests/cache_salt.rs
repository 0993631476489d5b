//! The cache salt covers every source a node's result can depend on (`build.rs`).
//!
//! A key hashes the engine salt (`SALTED_SOURCES`: every source but the operators' own files and
//! the layers above the operators) and the operator's own file (`OP_SOURCES`). That is sound
//! only if
//! - every file under `src/` is salted, an operator's own file, or in a layer above
//!   (`UNSALTED_LAYERS`);
//! - no salted file and no operator file uses another operator's file: a helper in operator A's
//!   file that operator B calls would change B's results without changing B's key (the
//!   `check_finite` that 12 operators took from `ReferenceSphere`'s file did exactly that). A
//!   domain's `mod.rs` may call its operators' `spec` to register them;
//! - nothing below uses a layer above, nor a crate whose version is left out
//!   (`UNSALTED_CRATES`);
//! - every file embedded with `include_bytes!`/`include_str!` is salted.
//!
//! The sources are read as tokens (comments, string contents and `#[cfg(test)]` items removed),
//! and every `crate::`/`super::`/`self::` path (and in a `mod.rs` every path through a child
//! module) is resolved to the file that defines its module, as rustc's module tree does.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use hdrflow::engine::cache::key::{SALTED_CRATES, SALTED_SOURCES, UNSALTED_CRATES, UNSALTED_LAYERS};
use hdrflow::engine::normalise::{embedded, normalise_source};
use hdrflow::ops::OP_SOURCES;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn rs_files(dir: &str) -> Vec<String> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(&Path::new(ROOT).join(dir), &mut out);
    let mut names: Vec<String> =
        out.iter().map(|p| p.strip_prefix(ROOT).unwrap().to_string_lossy().replace('\\', "/")).collect();
    names.sort();
    names
}

fn read(file: &str) -> String {
    std::fs::read_to_string(Path::new(ROOT).join(file)).unwrap()
}

fn above(file: &str) -> bool {
    UNSALTED_LAYERS.iter().any(|l| file == *l || file.starts_with(&format!("{l}/")))
}

fn salted(file: &str) -> bool {
    SALTED_SOURCES.contains(&file)
}

fn operator_file(file: &str) -> bool {
    OP_SOURCES.iter().any(|(f, _)| *f == file)
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Path,
    Punct(char),
}

fn ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// `text` as tokens, without comments; a string or char literal is one `Punct('"')`.
fn tokens(text: &str) -> Vec<Tok> {
    let c: Vec<char> = text.chars().collect();
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            loop {
                if at(i) == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if at(i) == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == '"' || ((ch == 'r' || ch == 'b') && (at(i + 1) == '"' || at(i + 1) == '#' || at(i + 1) == 'r'))
        {
            // "...", b"...", r"...", r#"..."#, br#"..."#
            let mut j = i;
            if c[j] == 'b' {
                j += 1;
            }
            let raw = at(j) == 'r';
            if raw {
                j += 1;
            }
            let hashes = (j..).take_while(|&k| at(k) == '#').count();
            j += hashes;
            if at(j) != '"' {
                // An identifier starting with r or b.
                let end = (i..).find(|&k| !ident_char(at(k))).unwrap();
                out.push(Tok::Ident(c[i..end].iter().collect()));
                i = end;
                continue;
            }
            j += 1;
            loop {
                if !raw && at(j) == '\\' {
                    j += 2;
                } else if at(j) == '"' && (0..hashes).all(|h| at(j + 1 + h) == '#') {
                    j += 1 + hashes;
                    break;
                } else {
                    j += 1;
                }
            }
            out.push(Tok::Punct('"'));
            i = j;
        } else if ch == '\'' {
            // 'c', '\n', '\u{..}', or a lifetime 'a.
            if at(i + 1) == '\\' {
                i = (i + 2..).find(|&k| at(k) == '\'').unwrap() + 1;
                out.push(Tok::Punct('"'));
            } else if at(i + 2) == '\'' {
                i += 3;
                out.push(Tok::Punct('"'));
            } else {
                i += 1;
            }
        } else if ident_char(ch) {
            let end = (i..).find(|&k| !ident_char(at(k))).unwrap();
            out.push(Tok::Ident(c[i..end].iter().collect()));
            i = end;
        } else if ch == ':' && at(i + 1) == ':' {
            out.push(Tok::Path);
            i += 2;
        } else {
            out.push(Tok::Punct(ch));
            i += 1;
        }
    }
    out
}

fn is(t: Option<&Tok>, ch: char) -> bool {
    t == Some(&Tok::Punct(ch))
}

fn ident(t: Option<&Tok>) -> Option<&str> {
    match t {
        Some(Tok::Ident(s)) => Some(s),
        _ => None,
    }
}

/// The index just past the bracketed group that opens at `i` (`open` .. `close`).
fn past_group(t: &[Tok], i: usize, open: char, close: char) -> usize {
    let mut depth = 0;
    for (k, tok) in t.iter().enumerate().skip(i) {
        if *tok == Tok::Punct(open) {
            depth += 1;
        } else if *tok == Tok::Punct(close) {
            depth -= 1;
            if depth == 0 {
                return k + 1;
            }
        }
    }
    t.len()
}

/// `t` without the items marked `#[cfg(test)]` (test code is in no result).
fn without_tests(t: Vec<Tok>) -> Vec<Tok> {
    let cfg_test = [
        Tok::Punct('#'),
        Tok::Punct('['),
        Tok::Ident("cfg".into()),
        Tok::Punct('('),
        Tok::Ident("test".into()),
        Tok::Punct(')'),
        Tok::Punct(']'),
    ];
    let mut out = Vec::new();
    let mut i = 0;
    while i < t.len() {
        if !t[i..].starts_with(&cfg_test) {
            out.push(t[i].clone());
            i += 1;
            continue;
        }
        i += cfg_test.len();
        while is(t.get(i), '#') && is(t.get(i + 1), '[') {
            i = past_group(&t, i + 1, '[', ']');
        }
        // The item: up to its `;`, or through its `{ ... }` block.
        while i < t.len() && !is(t.get(i), ';') && !is(t.get(i), '{') {
            i += 1;
        }
        i = if is(t.get(i), '{') { past_group(&t, i, '{', '}') } else { i + 1 };
    }
    out
}

/// The code of `file` (comments and tests removed).
fn code(file: &str) -> Vec<Tok> {
    if test_only(file) {
        return Vec::new();
    }
    without_tests(tokens(&read(file)))
}

/// Whether `file`'s parent declares it only for tests (`#[cfg(test)] mod tests;`): a test module
/// in a file of its own, which `without_tests` would not see as one.
fn test_only(file: &str) -> bool {
    let segs = module_of(file);
    let Some((name, parent)) = segs.split_last() else { return false };
    let parents = if parent.is_empty() {
        vec!["src/lib.rs".to_string()]
    } else {
        let dir = format!("src/{}", parent.join("/"));
        vec![format!("{dir}/mod.rs"), format!("{dir}.rs")]
    };
    let declared = [
        Tok::Punct('#'),
        Tok::Punct('['),
        Tok::Ident("cfg".into()),
        Tok::Punct('('),
        Tok::Ident("test".into()),
        Tok::Punct(')'),
        Tok::Punct(']'),
        Tok::Ident("mod".into()),
        Tok::Ident(name.clone()),
        Tok::Punct(';'),
    ];
    parents
        .iter()
        .filter(|p| Path::new(ROOT).join(p).exists())
        .any(|p| tokens(&read(p)).windows(declared.len()).any(|w| w == declared))
}

/// The module path of `file` (`src/a/b.rs` and `src/a/b/mod.rs` are `a::b`).
fn module_of(file: &str) -> Vec<String> {
    let rel = file.strip_prefix("src/").unwrap().strip_suffix(".rs").unwrap();
    let mut segs: Vec<String> = rel.split('/').map(String::from).collect();
    if segs.last().is_some_and(|s| s == "mod" || s == "lib") {
        segs.pop();
    }
    segs
}

/// The file that defines the module of absolute path `segs` (its longest prefix that is a
/// file module), and the segment after that prefix (the item named in that file).
fn resolve(segs: &[String]) -> (String, Option<String>) {
    for k in (1..=segs.len()).rev() {
        let base = format!("src/{}", segs[..k].join("/"));
        for candidate in [format!("{base}.rs"), format!("{base}/mod.rs")] {
            if Path::new(ROOT).join(&candidate).is_file() {
                return (candidate, segs.get(k).cloned());
            }
        }
    }
    ("src/lib.rs".into(), segs.first().cloned())
}

/// The paths of a use tree starting at `t[i]` after `prefix`: `a::b`, `a::{b, c::d}`, `a::*`.
fn use_tree(t: &[Tok], mut i: usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
    let mut path = prefix;
    loop {
        match t.get(i) {
            Some(Tok::Ident(s)) if s == "as" => return i,
            Some(Tok::Ident(s)) => {
                if s == "self" && !path.is_empty() {
                    // `a::{self, ...}` names `a` itself.
                } else {
                    path.push(s.clone());
                }
                i += 1;
            }
            Some(Tok::Punct('*')) => {
                path.push("*".into());
                i += 1;
            }
            Some(Tok::Punct('{')) => {
                i += 1;
                while !is(t.get(i), '}') && i < t.len() {
                    i = use_tree(t, i, path.clone(), out);
                    while !is(t.get(i), ',') && !is(t.get(i), '}') && i < t.len() {
                        i += 1; // `as name`
                    }
                    if is(t.get(i), ',') {
                        i += 1;
                    }
                }
                return i + 1;
            }
            _ => {
                out.push(path);
                return i;
            }
        }
        if t.get(i) != Some(&Tok::Path) || matches!(t.get(i + 1), Some(Tok::Punct('<'))) {
            out.push(path);
            return i;
        }
        i += 1;
    }
}

/// Every path of `file`'s code into the crate, resolved to (defining file, item named there).
fn references(file: &str) -> Vec<(String, Option<String>)> {
    let t = code(file);
    let file_module = module_of(file);
    let is_dir_module = file.ends_with("/mod.rs") || file == "src/lib.rs";
    // Child modules declared as files (`mod x;`), reachable by their bare name in a mod.rs.
    let children: BTreeSet<String> = (0..t.len())
        .filter(|&i| ident(t.get(i)) == Some("mod") && is(t.get(i + 2), ';'))
        .filter_map(|i| ident(t.get(i + 1)).map(String::from))
        .collect();
    // Inline modules (`mod x86 { ... }`) the scan is inside, with the brace depth they opened at.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let mut out = Vec::new();
    let mut i = 0;
    while i < t.len() {
        match &t[i] {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => {
                depth -= 1;
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
            }
            Tok::Ident(s) if s == "mod" && is(t.get(i + 2), '{') => {
                inline.push((ident(t.get(i + 1)).unwrap().to_string(), depth));
            }
            Tok::Ident(s) if t.get(i + 1) == Some(&Tok::Path) && t.get(i.wrapping_sub(1)) != Some(&Tok::Path) => {
                let mut base: Vec<String> =
                    file_module.iter().cloned().chain(inline.iter().map(|(m, _)| m.clone())).collect();
                let mut j = i;
                match s.as_str() {
                    "crate" => {
                        base.clear();
                        j += 2;
                    }
                    "self" | "super" => {
                        while let Some(w @ ("self" | "super")) = ident(t.get(j)) {
                            if w == "super" {
                                base.pop();
                            }
                            j += 2;
                        }
                    }
                    child if is_dir_module && inline.is_empty() && children.contains(child) => {}
                    _ => {
                        i += 1;
                        continue;
                    }
                }
                let mut paths = Vec::new();
                let end = use_tree(&t, j, base, &mut paths);
                out.extend(paths.iter().map(|p| resolve(p)));
                i = end.max(i + 1);
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

#[test]
fn every_source_is_salted_or_an_operators_own_file_or_above_the_operators() {
    let mut wrong = Vec::new();
    for f in rs_files("src") {
        let kinds = [salted(&f), operator_file(&f), above(&f)];
        if kinds.iter().filter(|k| **k).count() != 1 {
            wrong.push(format!("{f}: salted, operator file, above = {kinds:?}"));
        }
    }
    for f in rs_files("vendor/exr/src") {
        if !salted(&f) {
            wrong.push(format!("{f}: the vendored decoder, not salted"));
        }
    }
    for f in SALTED_SOURCES {
        if !Path::new(ROOT).join(f).is_file() {
            wrong.push(format!("{f}: salted but not a file"));
        }
    }
    assert!(wrong.is_empty(), "sources outside the cache salt:\n{}", wrong.join("\n"));
    // The operator files are the files under src/ops that build an operator with `Op::new(`.
    for (f, _) in OP_SOURCES {
        assert!(f.starts_with("src/ops/") && read(f).contains("Op::new("), "{f}");
    }
    for spec in hdrflow::builtin_registry().all() {
        assert_ne!(spec.code_hash, [0; 32], "{}: a built-in operator without its own file's hash", spec.name);
    }
}

#[test]
fn no_salted_or_operator_file_uses_another_operators_file_or_a_layer_above() {
    let mut wrong = Vec::new();
    let below: Vec<String> = rs_files("src").into_iter().filter(|f| !above(f)).collect();
    for f in &below {
        for (target, item) in references(f) {
            if target == *f || salted(&target) {
                continue;
            }
            // A domain's mod.rs registers its operators: `exposure::spec()`.
            let registers = operator_file(&target)
                && item.as_deref() == Some("spec")
                && Path::new(&target).parent() == Path::new(f).parent();
            if !registers {
                wrong.push(format!("{f} uses {target} ({})", item.unwrap_or_default()));
            }
        }
    }
    wrong.dedup();
    assert!(
        wrong.is_empty(),
        "these uses escape the cache keys (move a shared helper out of the operator's file, into a \
         shared file such as src/ops/latlong_input.rs):\n{}",
        wrong.join("\n")
    );
}

#[test]
fn references_resolve_as_the_module_tree_does() {
    // The scan itself: the helper that used to escape is seen, in every form it was written in.
    let uses =
        |f: &str| references(f).into_iter().map(|(t, i)| format!("{t} {}", i.unwrap_or_default())).collect::<Vec<_>>();
    assert!(uses("src/ops/shading/glossy_sphere.rs").contains(&"src/ops/latlong_input.rs check_finite".into()));
    assert!(uses("src/ops/shading/sh_sphere.rs").contains(&"src/ops/latlong_input.rs check_finite".into()));
    assert!(uses("src/ops/shading/mod.rs").contains(&"src/ops/shading/reference_sphere.rs spec".into()));
    assert!(uses("src/ops/shading/reference_sphere.rs").contains(&"src/ops/shading/mod.rs sphere_view".into()));
    let t = tokens("use super::reference_sphere::check_finite; // crate::cli::x\nlet s = \"crate::cli\";");
    assert_eq!(t.iter().filter(|t| **t == Tok::Ident("cli".into())).count(), 0);
    let t = without_tests(tokens("fn a() {}\n#[cfg(test)]\nmod tests { use crate::cli::x; }\nfn b() {}"));
    assert_eq!(t.iter().filter(|t| matches!(t, Tok::Ident(s) if s == "cli" || s == "tests")).count(), 0);
    assert!(t.contains(&Tok::Ident("b".into())));
}

#[test]
fn files_embedded_by_salted_sources_are_salted() {
    // The scan is `build.rs`'s own (`normalise::embedded`, one declaration for both); this checks
    // that what it finds in the sources below the layers above is what the salt lists.
    for f in rs_files("src").into_iter().filter(|f| !above(f)) {
        for path in embedded(Path::new(&f), &normalise_source(&read(&f))) {
            let path = path.to_string_lossy().replace('\\', "/");
            assert!(SALTED_SOURCES.contains(&path.as_str()), "{f} embeds {path}, not salted");
        }
    }
    assert!(SALTED_SOURCES.contains(&"assets/fonts/DejaVuSans.ttf"));
}

#[test]
fn crates_left_out_of_the_salt_are_used_only_above_the_operators() {
    for f in rs_files("src").into_iter().filter(|f| !above(f)) {
        let t = code(&f);
        for (package, name) in UNSALTED_CRATES {
            let used = (0..t.len()).any(|i| {
                ident(t.get(i)) == Some(*name)
                    && t.get(i + 1) == Some(&Tok::Path)
                    && t.get(i.wrapping_sub(1)) != Some(&Tok::Path)
            });
            assert!(!used, "{f} uses {package}, whose version is left out of the cache salt");
        }
    }
    for name in ["exr", "half", "glam", "image", "plotters", "statrs"] {
        assert!(SALTED_CRATES.iter().any(|c| c.starts_with(&format!("{name} "))), "{name} not salted");
    }
    assert!(!SALTED_CRATES.iter().any(|c| c.starts_with("clap ")));
}
