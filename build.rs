//! Computes the code hashes that go into every cache key, so that a shared cache never serves a
//! result computed by different code:
//!
//! - **The engine salt** (`ENGINE_SALT`): BLAKE3 over every source an operator's result can
//!   depend on, except operators' own files. That is every `.rs` file under `src/` but those of
//!   the layers above the operators (`UNSALTED_LAYERS`: the command line, the benchmark, the
//!   report, batch runs, the engine presets of `hdrflow bake`, which only build pipelines and
//!   present results) and the operator files; the files those sources embed
//!   (`include_bytes!`/`include_str!`, e.g. the plots' font); the vendored EXR decoder
//!   (`vendor/exr`); the values of the `env!` variables they read (the package version, written
//!   into KTX2 files); and the Cargo.lock version of every crate they build on
//!   (`UNSALTED_CRATES` lists the dependencies only the layers above, the tests and the
//!   benchmarks use). Sources are hashed with comments and blank space removed.
//! - **Each operator's code hash** (`OP_SOURCES`): the hash of its own file (an operator file is
//!   a file under `src/ops` that builds an operator with `Op::new(`), so that editing one operator leaves
//!   the other operators' cache entries valid.
//!
//! `tests/cache_salt.rs` checks the split: every source file is salted, an operator's own file
//! or in a layer above; no salted or operator file uses another operator's file (a helper two
//! operators share belongs in a shared file) or a layer above; no crate left out is used below.

#[path = "src/engine/normalise.rs"]
mod normalise;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Layers above the operators: they parse, schedule whole runs, build pipelines and present
/// results, but never compute a node's value, so their code is in no key.
const UNSALTED_LAYERS: &[&str] = &["src/cli", "src/bench", "src/report", "src/batch", "src/ibl_presets", "src/main.rs"];

/// Cargo.lock packages whose versions are left out of the salt, as (package, name in code):
/// dependencies that only the layers above (`UNSALTED_LAYERS`), the tests, the benchmarks or
/// this build script use (the lock does not tell dev- and build-dependencies apart). Their own
/// dependencies still count when a salted crate also depends on them.
const UNSALTED_CRATES: &[(&str, &str)] = &[
    ("clap", "clap"),
    ("clap_complete", "clap_complete"),
    ("clap_mangen", "clap_mangen"),
    ("indicatif", "indicatif"),
    ("notify", "notify"),
    ("ctrlc", "ctrlc"),
    ("layout-rs", "layout"),
    ("base64", "base64"),
    ("csv", "csv"),
    ("ron", "ron"),
    ("proptest", "proptest"),
    ("criterion", "criterion"),
    ("tempfile", "tempfile"),
    ("ktx2", "ktx2"),
];

/// Every `.rs` file under `dir`, or every file when `all`.
fn collect(dir: &Path, all: bool, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect(&p, all, out);
        } else if all || p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

fn rel(p: &Path) -> String {
    p.to_string_lossy().replace('\\', "/")
}

/// The variables `text` reads with `env!`/`option_env!`, but the crate folder (used for paths
/// only) and `OUT_DIR`.
fn env_vars(text: &str, out: &mut BTreeSet<String>) {
    for (at, _) in text.match_indices("env!(\"") {
        let rest = &text[at + "env!(\"".len()..];
        let name = &rest[..rest.find('"').unwrap_or(0)];
        if name != "CARGO_MANIFEST_DIR" && name != "OUT_DIR" {
            out.insert(name.to_string());
        }
    }
}

/// `name version` of every package of `lock` (Cargo.lock's text) that `root` depends on,
/// directly or not, through no crate of `UNSALTED_CRATES`.
fn locked_dependencies(lock: &str, root: &str) -> Vec<String> {
    // name -> [(version, dependencies)]
    let mut packages: BTreeMap<&str, Vec<(&str, Vec<&str>)>> = BTreeMap::new();
    for block in lock.split("[[package]]").skip(1) {
        let field = |key: &str| {
            block.lines().find_map(|l| l.strip_prefix(key)).map(|v| v.trim().trim_matches('"')).unwrap_or("")
        };
        let deps = match block.split_once("dependencies = [") {
            Some((_, list)) => list[..list.find(']').unwrap_or(0)]
                .split(',')
                .map(|d| d.trim().trim_matches('"'))
                .filter(|d| !d.is_empty())
                .collect(),
            None => Vec::new(),
        };
        packages.entry(field("name = ")).or_default().push((field("version = "), deps));
    }
    let mut seen = BTreeSet::new();
    let mut todo = vec![root.to_string()];
    while let Some(dep) = todo.pop() {
        // "name", or "name version" (or "name version (source)") when several versions are locked.
        let mut words = dep.split(' ');
        let name = words.next().unwrap_or("");
        let version = words.next();
        if UNSALTED_CRATES.iter().any(|(p, _)| *p == name) {
            continue;
        }
        let Some(versions) = packages.get(name) else { continue };
        for (v, deps) in versions.iter().filter(|(v, _)| version.is_none_or(|w| w == *v)) {
            if seen.insert(format!("{name} {v}")) {
                todo.extend(deps.iter().map(|d| d.to_string()));
            }
        }
    }
    seen.remove(&format!("{root} {}", std::env::var("CARGO_PKG_VERSION").unwrap_or_default()));
    seen.into_iter().collect()
}

fn main() {
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=vendor/exr");
    println!("cargo:rerun-if-changed=Cargo.lock");

    let mut sources = Vec::new();
    collect(Path::new("src"), false, &mut sources);
    sources.sort();
    let mut salted = BTreeSet::new();
    let mut op_files = Vec::new();
    let mut vars = BTreeSet::new();
    for f in sources {
        let name = rel(&f);
        if UNSALTED_LAYERS.iter().any(|l| name == *l || name.starts_with(&format!("{l}/"))) {
            continue;
        }
        let text = normalise::normalise_source(&std::fs::read_to_string(&f).unwrap_or_default());
        env_vars(&text, &mut vars);
        for e in normalise::embedded(&f, &text) {
            println!("cargo:rerun-if-changed={}", rel(&e));
            salted.insert(e);
        }
        if name.starts_with("src/ops/") && text.contains("Op::new(") {
            op_files.push((name, text));
        } else {
            salted.insert(f);
        }
    }
    let mut vendored = Vec::new();
    collect(Path::new("vendor/exr/src"), false, &mut vendored);
    salted.extend(vendored);
    salted.insert(PathBuf::from("vendor/exr/Cargo.toml"));

    let mut h = blake3::Hasher::new();
    for f in &salted {
        h.update(rel(f).as_bytes());
        h.update(&[0]);
        let bytes = std::fs::read(f).unwrap_or_default();
        if f.extension().is_some_and(|e| e == "rs") {
            h.update(normalise::normalise_source(&String::from_utf8_lossy(&bytes)).as_bytes());
        } else {
            h.update(&bytes);
        }
        h.update(&[0]);
    }
    for v in &vars {
        // Cargo's own `CARGO_*` values change only with Cargo.toml, which reruns this script
        // anyway; asking to rerun on them would rebuild the crate whenever a process that cargo
        // started (a test running `cargo run --example`) calls cargo again with them set.
        if !v.starts_with("CARGO_") {
            println!("cargo:rerun-if-env-changed={v}");
        }
        h.update(format!("env {v}={:?}\0", std::env::var(v).ok()).as_bytes());
    }
    let lock = std::fs::read_to_string("Cargo.lock").unwrap_or_default();
    let crates = locked_dependencies(&lock, &std::env::var("CARGO_PKG_NAME").unwrap_or_default());
    for c in &crates {
        h.update(format!("crate {c}\0").as_bytes());
    }
    let hash = h.finalize();

    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let bytes = |hash: &blake3::Hash| hash.as_bytes().iter().map(|b| b.to_string()).collect::<Vec<_>>().join(", ");
    let strs = |items: &mut dyn Iterator<Item = String>| items.map(|s| format!("{s:?}")).collect::<Vec<_>>().join(", ");
    let salted_names = strs(&mut salted.iter().map(|f| rel(f)));
    std::fs::write(
        out_dir.join("engine_salt.rs"),
        format!(
            "/// BLAKE3 of every source operators build on ({} files, {} variables, {} locked crates; see `build.rs`).\n\
             pub const ENGINE_SALT: [u8; 32] = [{}];\n\
             /// The files [`ENGINE_SALT`] covers, relative to the crate.\n\
             pub const SALTED_SOURCES: &[&str] = &[{salted_names}];\n\
             /// The folders and files of `src` above the operators, in no key.\n\
             pub const UNSALTED_LAYERS: &[&str] = &[{}];\n\
             /// The Cargo.lock packages left out of [`ENGINE_SALT`], as (package, name in code).\n\
             pub const UNSALTED_CRATES: &[(&str, &str)] = &{UNSALTED_CRATES:?};\n\
             /// `name version` of the Cargo.lock packages [`ENGINE_SALT`] covers.\n\
             pub const SALTED_CRATES: &[&str] = &[{}];\n",
            salted.len(),
            vars.len(),
            crates.len(),
            bytes(&hash),
            strs(&mut UNSALTED_LAYERS.iter().map(|s| s.to_string())),
            strs(&mut crates.iter().cloned()),
        ),
    )
    .expect("writing engine_salt.rs");

    // Each built-in operator file's own hash (stamped by the registry, `Registry::hash_sources_with`), looked up by
    // the file's path: computed here because `file!()` is relative or absolute depending on how
    // the crate is built, so an operator cannot reliably `include_str!` itself by that path.
    let mut table = String::from("/// (operator source path relative to the crate, BLAKE3 of its normalised text).\npub const OP_SOURCES: &[(&str, [u8; 32])] = &[\n");
    for (name, text) in &op_files {
        table.push_str(&format!("    ({name:?}, [{}]),\n", bytes(&blake3::hash(text.as_bytes()))));
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("op_sources.rs"), table).expect("writing op_sources.rs");
}
