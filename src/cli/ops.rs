//! `hdrflow ops [NAME]`: every operator with its ports, fields, types, defaults and docs (from
//! its params struct), then the value types; an unknown NAME names the closest operators.
//! (`hdrflow ops --markdown DIR`, the same specs as the book's operator reference, is
//! `ops_markdown`.)

use std::process::ExitCode;

use super::op_text::{persist_text, save_extensions};
use crate::engine::graph::suggest;
use crate::engine::registry::Registry;

pub(super) fn ops(registry: &Registry, name: Option<&str>) -> ExitCode {
    let all = registry.all();
    let selected: Vec<_> = all.into_iter().filter(|s| name.is_none_or(|n| s.name.eq_ignore_ascii_case(n))).collect();
    if selected.is_empty() {
        eprintln!("error: {}", unknown_operator(name.unwrap_or(""), &registry.names()));
        return ExitCode::from(2);
    }
    let mut category = "";
    for spec in selected {
        if spec.category != category {
            category = spec.category;
            outln!("== {category} ==");
        }
        outln!("{} (v{})", spec.name, spec.version);
        outln!("    {}", spec.doc);
        outln!("    cache: {}", persist_text(spec.persist));
        for port in &spec.outputs {
            outln!("    -> {:<12} {:<40} {}", port.name, port.ty.describe(), port.doc);
        }
        if let Some(open) = &spec.open_ports {
            outln!("    -> {:<12} {:<40} {}", "<any>", open.ty.to_string(), open.doc);
        }
        for f in &spec.fields {
            outln!("    {:<15} {:<40} {:<22} {}", f.name, f.kind.describe(), f.describe_default(), f.doc);
        }
        if spec.name == "LoadHdr" {
            outln!("    built-in maps (path: \"builtin:NAME\"):");
            for (n, doc) in crate::formats::builtin::BUILTINS {
                outln!("      {n:<10} {doc}");
            }
        }
        outln!();
    }
    if name.is_none() {
        outln!("== value types ==");
        for t in registry.value_types() {
            let saves = save_extensions(registry, t);
            let saved = if saves.is_empty() { String::new() } else { format!(" (Save: {saves})") };
            outln!("    {:<14} {}{saved}", t.name(), t.spec().doc);
        }
    }
    ExitCode::SUCCESS
}

/// The message for an operator name that is not registered: the closest names when some are
/// close (`Rotat`: did you mean "Rotate"?), else every operator.
fn unknown_operator(name: &str, names: &[&str]) -> String {
    match suggest(name, names, "operators") {
        close if close.starts_with(';') => format!("no operator {name:?}{close}"),
        _ => format!("no operator {name:?} (operators: {})", names.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use std::process::ExitCode;

    use super::unknown_operator;
    use crate::cli::testing::{exit_code, parse_error};

    /// An unknown operator is a usage error (2); names match regardless of case.
    #[test]
    fn an_unknown_operator_exits_2() {
        assert_eq!(exit_code(&["ops", "NoSuchOperator"]), ExitCode::from(2));
        assert_eq!(parse_error(&["ops", "a", "b"]).0, clap::error::ErrorKind::UnknownArgument);
    }

    /// A near miss names the closest operators; a name close to none lists them all.
    #[test]
    fn an_unknown_operator_names_the_closest_ones() {
        let names = ["LoadHdr", "Rotate", "Resize", "Sample"];
        assert_eq!(unknown_operator("Rotat", &names), "no operator \"Rotat\"; did you mean \"Rotate\"?");
        assert_eq!(unknown_operator("loadhrd", &names), "no operator \"loadhrd\"; did you mean \"LoadHdr\"?");
        assert_eq!(
            unknown_operator("Zzzzzzzz", &names),
            "no operator \"Zzzzzzzz\" (operators: LoadHdr, Rotate, Resize, Sample)"
        );
    }
}
