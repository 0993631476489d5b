//! `hdrflow ops --markdown DIR`: the operator reference of the book, one page per operator
//! (`DIR/<Name>.md`: category, one-line doc, version, cache class, fields with their type,
//! range, accepted input types, default and doc, output ports) and `DIR/index.md` (the
//! operators by category with links, then the value types). The text comes from the registry's
//! specs, the same data `hdrflow ops` prints, with its formatting of types, ranges and defaults
//! (`FieldKind::describe`, `FieldKind::range`, `FieldSpec::describe_default`).
//!
//! The pages are checked in at `docs/src/reference/operators/`; `tests/operator_reference.rs`
//! fails when they differ from what the binary writes, so they cannot drift from the code.

use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;

use crate::engine::cache::store::write_atomic;
use crate::engine::op::OpSpec;
use crate::engine::params::{with_range, Arity, FieldKind, FieldSpec};
use crate::engine::registry::Registry;

/// The command that writes the checked-in pages (printed in each page and by the test).
const REGENERATE: &str = "cargo run --release -- ops --markdown docs/src/reference/operators";

/// `hdrflow ops --markdown DIR`: every operator's page and the index written into `dir`.
pub(super) fn markdown(registry: &Registry, dir: &Path) -> ExitCode {
    match write_pages(registry, &registry.all(), dir) {
        Ok(n) => {
            outln!("{n} operator pages and index.md written to {}", dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// Writes one page per operator of `specs` and `index.md` into `dir` (created if missing);
/// returns the number of operator pages.
fn write_pages(registry: &Registry, specs: &[&Arc<OpSpec>], dir: &Path) -> Result<usize, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))
    };
    for spec in specs {
        write(&format!("{}.md", spec.name), page(spec))?;
    }
    write("index.md", index(registry, specs))?;
    Ok(specs.len())
}

/// The page of one operator.
fn page(spec: &OpSpec) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {}\n", spec.name);
    let _ = writeln!(s, "{}\n", cell(spec.doc));
    let _ = writeln!(s, "- **Category**: [{0}](index.md#{0})", spec.category);
    let _ = writeln!(s, "- **Version**: {} (in the cache key: bumped whenever results may change)", spec.version);
    let _ = writeln!(s, "- **Cache**: {}\n", super::op_text::persist_text(spec.persist));

    let _ = writeln!(s, "## Fields\n");
    if spec.fields.is_empty() {
        let _ = writeln!(s, "None.\n");
    } else {
        let _ = writeln!(s, "| field | type | default | description |");
        let _ = writeln!(s, "|---|---|---|---|");
        for f in &spec.fields {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} |",
                f.name,
                cell(&field_type(&f.kind)),
                cell(&default_text(f)),
                cell(&f.doc)
            );
        }
        let _ = writeln!(s);
    }

    let _ = writeln!(s, "## Output ports\n");
    let _ = writeln!(
        s,
        "The first port is the default: a field that names the node (`\"node\"`) takes it, \
         `\"node.port\"` takes the port named.\n"
    );
    let _ = writeln!(s, "| port | type | description |");
    let _ = writeln!(s, "|---|---|---|");
    for port in &spec.outputs {
        let _ = writeln!(s, "| `{}` | {} | {} |", port.name, cell(&port.ty.describe()), cell(port.doc));
    }
    if let Some(open) = &spec.open_ports {
        let _ = writeln!(s, "| any other name | {} | {} |", cell(open.ty.name()), cell(open.doc));
    }
    let _ = writeln!(s);

    if spec.name == "LoadHdr" {
        let _ = writeln!(s, "## Built-in maps\n");
        let _ = writeln!(s, "`path: \"builtin:NAME\"` loads one of these instead of a file.\n");
        let _ = writeln!(s, "| name | map |");
        let _ = writeln!(s, "|---|---|");
        for (n, doc) in crate::formats::builtin::BUILTINS {
            let _ = writeln!(s, "| `{n}` | {} |", cell(doc));
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "---\n\n*Generated from the operator's spec (what `hdrflow ops {}` prints) by `{REGENERATE}`: \
         do not edit by hand.*",
        spec.name
    );
    s
}

/// The index: every operator by category, with a link and its one-line doc, then the value types.
fn index(registry: &Registry, specs: &[&Arc<OpSpec>]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Operator reference\n");
    let mut categories: Vec<&str> = specs.iter().map(|o| o.category).collect();
    categories.dedup();
    let _ = writeln!(
        s,
        "Every operator, {} in {} categories (a category is the folder of `src/ops/` the operator's file is in), \
         with its fields, their types, ranges and defaults, and its output ports. These pages are generated \
         from the registry's specs, the same data `hdrflow ops` prints, by `{REGENERATE}`; a test fails when \
         they differ from what the binary writes.\n",
        specs.len(),
        categories.len()
    );
    let _ = writeln!(
        s,
        "Categories: {}.\n",
        categories.iter().map(|c| format!("[{c}](#{c})")).collect::<Vec<_>>().join(", ")
    );
    for category in categories {
        let _ = writeln!(s, "## {category}\n");
        let _ = writeln!(s, "| operator | version | what it does |");
        let _ = writeln!(s, "|---|---|---|");
        for spec in specs.iter().filter(|o| o.category == category) {
            let _ = writeln!(s, "| [{0}]({0}.md) | {1} | {2} |", spec.name, spec.version, cell(spec.doc));
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Value types\n");
    let _ = writeln!(s, "What flows between nodes; an input field accepts the types its page lists.\n");
    let _ = writeln!(s, "| type | what it is | Save writes it as |");
    let _ = writeln!(s, "|---|---|---|");
    for t in registry.value_types() {
        let saves = super::op_text::save_extensions(registry, t);
        let _ = writeln!(s, "| `{}` | {} | {} |", t.name(), cell(t.spec().doc), cell(&saves));
    }
    s
}

/// The field's type with its range, and for an input the value types it accepts:
/// `float in [0, 1]`, `input: image, scalar field`, `list of 1 to 64 inputs: image`,
/// `Rec709 | Rec2020`. Numbers print as `hdrflow ops` prints them (`FieldKind::range`: `in [0, 1]`,
/// `>= 0`); an unbounded range is left out.
fn field_type(kind: &FieldKind) -> String {
    let length = match kind.length() {
        Some((min, usize::MAX)) => format!("{min} or more "),
        Some((min, max)) if min == max => format!("{min} "),
        Some((min, max)) => format!("{min} to {max} "),
        None => String::new(),
    };
    match kind {
        FieldKind::Input { types, arity } => {
            let accepts = if types.is_empty() {
                "any type".to_string()
            } else {
                types.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ")
            };
            match arity {
                Arity::One => format!("input: {accepts}"),
                Arity::Optional => format!("optional input: {accepts}"),
                Arity::List { .. } => format!("list of {length}inputs: {accepts}"),
            }
        }
        FieldKind::Float { .. } => with_range("float", kind.range()),
        FieldKind::Int { .. } => with_range("integer", kind.range()),
        FieldKind::Tuple { len, .. } => with_range(&format!("{len} floats"), kind.range()),
        FieldKind::Color { .. } => with_range("(r, g, b) or grey", kind.range()),
        FieldKind::NumberList { .. } => with_range(&format!("list of {length}numbers"), kind.range()),
        FieldKind::TextList { .. } => format!("list of {length}strings"),
        other => other.describe(),
    }
}

/// The default as `hdrflow ops` prints it, in a column of its own: `0.5`, `required`, `optional`.
fn default_text(field: &FieldSpec) -> String {
    let d = field.describe_default();
    d.strip_prefix("default ").map(str::to_string).unwrap_or(d)
}

/// Text made safe for a Markdown table cell: pipes escaped, angle brackets as entities (a doc's
/// `<any>` is no HTML tag), `*` escaped, newlines as spaces.
fn cell(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '|' => out.push_str("\\|"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '*' => out.push_str("\\*"),
            '\n' => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{cell, field_type};
    use crate::engine::params::{Arity, FieldKind};

    #[test]
    fn cells_escape_what_markdown_would_read() {
        assert_eq!(cell("Ggx | Charlie"), "Ggx \\| Charlie");
        assert_eq!(cell("ports <any>, a*b"), "ports &lt;any&gt;, a\\*b");
    }

    #[test]
    fn types_give_ranges_list_lengths_and_accepted_types() {
        assert_eq!(field_type(&FieldKind::Float { min: 0.0, max: f64::INFINITY }), "float >= 0");
        assert_eq!(field_type(&FieldKind::Int { min: i64::MIN, max: 7 }), "integer <= 7");
        assert_eq!(field_type(&FieldKind::Tuple { len: 9, min: -f64::MAX, max: f64::MAX }), "9 floats");
        assert_eq!(
            field_type(&FieldKind::Input { types: vec![], arity: Arity::List { min: 1, max: 64 } }),
            "list of 1 to 64 inputs: any type"
        );
        assert_eq!(
            field_type(&FieldKind::NumberList { min_len: 1, max_len: usize::MAX, min: 0.0, max: 100.0 }),
            "list of 1 or more numbers in [0, 100]"
        );
        assert_eq!(field_type(&FieldKind::Bool), "bool");
    }
}
