//! Computes the engine's code salt: BLAKE3 of every source file that operators build on (the
//! engine, value types, maths, formats, plotting and the operators' shared domain
//! modules), each with comments and blank space removed. It goes into every cache key, so a
//! shared cache never serves a result computed by different code. Each operator adds the hash
//! of its own file (`OpSpec::code`).

#[path = "src/engine/normalise.rs"]
mod normalise;

use std::path::{Path, PathBuf};

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=src");
    let mut files = Vec::new();
    for dir in ["src/engine", "src/values", "src/maths", "src/formats", "src/plotting", "src/geometry"] {
        collect(Path::new(dir), &mut files);
    }
    // The operators' shared domain modules (field helpers, common code), not the operators.
    let mut ops = Vec::new();
    collect(Path::new("src/ops"), &mut ops);
    files.extend(ops.into_iter().filter(|p| p.file_name().is_some_and(|n| n == "mod.rs")));
    files.sort();
    let mut h = blake3::Hasher::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap_or_default();
        let rel = f.to_string_lossy().replace('\\', "/");
        h.update(rel.as_bytes());
        h.update(&[0]);
        h.update(normalise::normalise_source(&text).as_bytes());
        h.update(&[0]);
    }
    let hash = h.finalize();
    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let bytes = |hash: &blake3::Hash| hash.as_bytes().iter().map(|b| b.to_string()).collect::<Vec<_>>().join(", ");
    std::fs::write(
        out_dir.join("engine_salt.rs"),
        format!(
            "/// BLAKE3 of the engine's and shared layers' normalised sources ({} files).\npub const ENGINE_SALT: [u8; 32] = [{}];\n",
            files.len(),
            bytes(&hash)
        ),
    )
    .expect("writing engine_salt.rs");

    // Each built-in operator file's own hash (`OpSpec::code_hash(op_code_hash!())`), looked up by
    // the file's path: computed here because `file!()` is relative or absolute depending on how
    // the crate is built, so an operator cannot reliably `include_str!` itself by that path.
    let mut table = String::from("/// (operator source path relative to the crate, BLAKE3 of its normalised text).\npub const OP_SOURCES: &[(&str, [u8; 32])] = &[\n");
    let mut op_files = Vec::new();
    collect(Path::new("src/ops"), &mut op_files);
    op_files.sort();
    for f in &op_files {
        let text = std::fs::read_to_string(f).unwrap_or_default();
        let rel = f.to_string_lossy().replace('\\', "/");
        let hash = blake3::hash(normalise::normalise_source(&text).as_bytes());
        table.push_str(&format!("    ({rel:?}, [{}]),\n", bytes(&hash)));
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("op_sources.rs"), table).expect("writing op_sources.rs");
}
