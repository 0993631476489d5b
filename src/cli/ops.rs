//! `hdrflow ops [NAME]`: every operator with its ports, fields, types, defaults and docs (from
//! its params struct), then the value types.

use std::process::ExitCode;

use crate::engine::cache::Persist;
use crate::engine::registry::Registry;

pub(super) fn ops(registry: &Registry, name: Option<&str>) -> ExitCode {
    let all = registry.all();
    let selected: Vec<_> = all.iter().filter(|s| name.is_none_or(|n| s.name.eq_ignore_ascii_case(n))).collect();
    if selected.is_empty() {
        eprintln!("error: no operator {:?} (operators: {})", name.unwrap_or(""), registry.names().join(", "));
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
        outln!(
            "    cache: {}",
            match spec.persist {
                Persist::Measured => "a large result is stored when slower to recompute than to read back",
                Persist::Always => "every result is stored",
                Persist::IfSmall => "a large result is stored only as a target (one cheap pass per byte)",
            }
        );
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
            let saves = registry.saver(t).map_or(&[][..], |s| s.extensions);
            let saved = if saves.is_empty() {
                String::new()
            } else {
                format!(" (Save: {})", saves.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(" "))
            };
            outln!("    {:<14} {}{saved}", t.name(), t.spec().doc);
        }
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use std::process::ExitCode;

    use crate::cli::testing::{exit_code, parse_error};

    /// An unknown operator is a usage error (2); names match regardless of case.
    #[test]
    fn an_unknown_operator_exits_2() {
        assert_eq!(exit_code(&["ops", "NoSuchOperator"]), ExitCode::from(2));
        assert_eq!(parse_error(&["ops", "a", "b"]).0, clap::error::ErrorKind::UnknownArgument);
    }
}
