//! A written literal converted to its field's parameter type, with the range checked.

use super::outputs::check_output_path;
use super::suggest::suggest_close;
use crate::engine::graph::syntax::{Ron, Spanned};
use crate::engine::params::{fmt_range, FieldKind, FieldSpec, ParamValue};

/// Converts a literal to the field's parameter type, checking its range.
pub(super) fn convert(field: &FieldSpec, value: &Ron) -> Result<ParamValue, String> {
    let found = || format!("expected {}, found {}", field.kind.describe(), describe_literal(value));
    let number = |v: &Ron| match v {
        Ron::Float(v) => Some(*v),
        Ron::Int(v) => Some(*v as f64),
        _ => None,
    };
    match &field.kind {
        FieldKind::Input { .. } => unreachable!("inputs are edges"),
        FieldKind::Float { min, max } => {
            let v = number(value).ok_or_else(found)?;
            if v.is_nan() || v < *min || v > *max {
                return Err(format!("{v} is out of range (expected {})", field.kind.describe()));
            }
            Ok(ParamValue::Float(v))
        }
        FieldKind::Int { min, max } => match value {
            Ron::Int(v) if v >= min && v <= max => Ok(ParamValue::Int(*v)),
            Ron::Int(v) => Err(format!("{v} is out of range (expected {})", field.kind.describe())),
            _ => Err(found()),
        },
        FieldKind::Bool => match value {
            Ron::Bool(b) => Ok(ParamValue::Bool(*b)),
            _ => Err(found()),
        },
        FieldKind::Text | FieldKind::Path | FieldKind::InputPattern => match value {
            Ron::Str(s) => Ok(ParamValue::Text(s.clone())),
            _ => Err(found()),
        },
        FieldKind::OutputPath => match value {
            Ron::Str(s) => {
                check_output_path(s)?;
                Ok(ParamValue::Text(s.clone()))
            }
            _ => Err(found()),
        },
        FieldKind::TextList { min, max } => match value {
            Ron::List(items) => {
                if items.len() < *min || items.len() > *max {
                    return Err(format!("expected {min} to {max} strings, found {}", items.len()));
                }
                items
                    .iter()
                    .map(|i| match &i.value {
                        Ron::Str(s) => Ok(s.clone()),
                        _ => Err(found()),
                    })
                    .collect::<Result<_, _>>()
                    .map(ParamValue::TextList)
            }
            _ => Err(found()),
        },
        FieldKind::Choice(options) => match value {
            Ron::Ident(s) | Ron::Str(s) if options.contains(&s.as_str()) => Ok(ParamValue::Choice(s.clone())),
            Ron::Ident(s) | Ron::Str(s) => {
                Err(format!("{s:?} is not one of {}{}", options.join(", "), suggest_close(s, options)))
            }
            _ => Err(found()),
        },
        FieldKind::Tuple { len, min, max } => match value {
            Ron::Tuple { name: None, items } if items.len() == *len => tuple(items, *min, *max, found),
            _ => Err(found()),
        },
        FieldKind::Color { min, max } => match value {
            Ron::Tuple { name: None, items } if items.len() == 3 => tuple(items, *min, *max, found),
            Ron::Int(_) | Ron::Float(_) => {
                let v = number(value).expect("a number");
                if v.is_nan() || v < *min || v > *max {
                    return Err(out_of_range(&v.to_string(), *min, *max));
                }
                Ok(ParamValue::Tuple(vec![v; 3]))
            }
            _ => Err(found()),
        },
        FieldKind::NumberList { min_len, max_len, min, max } => match value {
            Ron::List(items) | Ron::Tuple { name: None, items } => {
                if items.len() < *min_len || items.len() > *max_len {
                    return Err(format!("expected {min_len} to {max_len} numbers, found {}", items.len()));
                }
                tuple(items, *min, *max, found)
            }
            _ => Err(found()),
        },
    }
}

/// "`what` is out of range [min, max]" (or `<= max`, `>= min`; a NaN is out of any range).
fn out_of_range(what: &str, min: f64, max: f64) -> String {
    match fmt_range(min, max) {
        Some(range) => format!("{what} is out of range {range}"),
        None => format!("{what} is not a number"),
    }
}

fn tuple(items: &[Spanned<Ron>], min: f64, max: f64, found: impl Fn() -> String) -> Result<ParamValue, String> {
    let mut out = Vec::with_capacity(items.len());
    for item in items {
        let v = match item.value {
            Ron::Float(v) => v,
            Ron::Int(v) => v as f64,
            _ => return Err(found()),
        };
        if v.is_nan() || v < min || v > max {
            return Err(out_of_range(&format!("component {v}"), min, max));
        }
        out.push(v);
    }
    Ok(ParamValue::Tuple(out))
}

fn describe_literal(value: &Ron) -> String {
    match value {
        Ron::Str(s) => format!("string {s:?}"),
        Ron::Int(v) => format!("integer {v}"),
        Ron::Float(v) => format!("float {v}"),
        Ron::Bool(b) => format!("bool {b}"),
        Ron::Ident(s) => format!("identifier {s}"),
        Ron::Tuple { items, .. } => format!("a tuple of {}", items.len()),
        other => other.kind_name().to_string(),
    }
}
