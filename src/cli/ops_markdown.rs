//! `hdrflow ops --markdown DIR`: the operator reference of the book, one page per operator
//! (`DIR/<Name>.md`: category, one-line doc, version, cache class, fields with type, accepted
//! input types, range, default and doc, output ports) and `DIR/index.md` (the operators by
//! category with links, then the value types). The text comes from the registry's specs, the
//! same data `hdrflow ops` prints, with its formatting of types, ranges and defaults
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
use crate::engine::params::{Arity, FieldKind};
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
    let _ = writeln!(s, "- **Cache**: {}\n", super::ops::persist_text(spec.persist));

    let _ = writeln!(s, "## Fields\n");
    if spec.fields.is_empty() {
        let _ = writeln!(s, "None.\n");
    } else {
        let _ = writeln!(s, "| field | type | accepts | range | default | description |");
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        for f in &spec.fields {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} | {} | {} |",
                f.name,
                cell(&field_type(&f.kind)),
                cell(&accepts(&f.kind)),
                cell(&range(&f.kind)),
                cell(&f.describe_default()),
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
        let saves = super::ops::save_extensions(registry, t);
        let _ = writeln!(s, "| `{}` | {} | {} |", t.name(), cell(t.spec().doc), cell(&saves));
    }
    s
}

/// The field's type without its range: `float`, `input`, `Rec709 | Rec2020`, ...
fn field_type(kind: &FieldKind) -> String {
    match kind {
        FieldKind::Input { arity: Arity::One, .. } => "input".into(),
        FieldKind::Input { arity: Arity::Optional, .. } => "optional input".into(),
        FieldKind::Input { arity: Arity::List { .. }, .. } => "list of inputs".into(),
        FieldKind::Float { .. } => "float".into(),
        FieldKind::Int { .. } => "integer".into(),
        FieldKind::NumberList { .. } => "list of numbers".into(),
        other => other.describe(),
    }
}

/// The value types an input accepts (`any` when it takes every type); empty for a parameter.
fn accepts(kind: &FieldKind) -> String {
    match kind {
        FieldKind::Input { types, .. } if types.is_empty() => "any".into(),
        FieldKind::Input { types, .. } => types.iter().map(|t| t.name()).collect::<Vec<_>>().join(", "),
        _ => String::new(),
    }
}

/// The range of the values and, for a list, of its length.
fn range(kind: &FieldKind) -> String {
    let length = kind.length().map(|(min, max)| match max {
        usize::MAX => format!("length {min} or more"),
        max if max == min => format!("length {min}"),
        max => format!("length {min} to {max}"),
    });
    [kind.range(), length].into_iter().flatten().collect::<Vec<_>>().join("; ")
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
    use super::{cell, range};
    use crate::engine::params::{Arity, FieldKind};

    #[test]
    fn cells_escape_what_markdown_would_read() {
        assert_eq!(cell("Ggx | Charlie"), "Ggx \\| Charlie");
        assert_eq!(cell("ports <any>, a*b"), "ports &lt;any&gt;, a\\*b");
    }

    #[test]
    fn ranges_give_values_and_list_lengths() {
        assert_eq!(range(&FieldKind::Float { min: 0.0, max: f64::INFINITY }), "[0, inf]");
        assert_eq!(
            range(&FieldKind::Input { types: vec![], arity: Arity::List { min: 1, max: 64 } }),
            "length 1 to 64"
        );
        assert_eq!(
            range(&FieldKind::NumberList { min_len: 1, max_len: usize::MAX, min: 0.0, max: 100.0 }),
            "[0, 100]; length 1 or more"
        );
        assert_eq!(range(&FieldKind::Bool), "");
    }
}
