//! JSON text for displayed and saved values: indented like `serde_json`'s pretty printer (two
//! spaces, keys in insertion order), except that an array of numbers, strings, booleans or nulls
//! stays on one line (`[0.25, 0.5, 1]`), so a colour, a direction or a matrix row reads as one.
//! Numbers are `serde_json`'s: the shortest decimal that reads back to the same f64.

use std::fmt::Write as _;

use serde_json::Value;

/// The JSON text of `v`, ending with a newline.
pub(crate) fn text(v: &Value) -> String {
    let mut out = String::new();
    write(&mut out, v, 0);
    out.push('\n');
    out
}

/// A JSON number, or `null` for NaN and infinities (JSON has neither).
pub(crate) fn num(v: f64) -> Value {
    serde_json::Number::from_f64(v).map(Value::Number).unwrap_or(Value::Null)
}

fn is_scalar(v: &Value) -> bool {
    !matches!(v, Value::Array(_) | Value::Object(_))
}

fn write(out: &mut String, v: &Value, depth: usize) {
    let pad = |out: &mut String, d: usize| out.extend(std::iter::repeat_n("  ", d));
    match v {
        Value::Array(items) if items.is_empty() => out.push_str("[]"),
        Value::Array(items) if items.iter().all(is_scalar) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                let _ = write!(out, "{}{item}", if i > 0 { ", " } else { "" });
            }
            out.push(']');
        }
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                out.push_str(if i > 0 { ",\n" } else { "\n" });
                pad(out, depth + 1);
                write(out, item, depth + 1);
            }
            out.push('\n');
            pad(out, depth);
            out.push(']');
        }
        Value::Object(map) if map.is_empty() => out.push_str("{}"),
        Value::Object(map) => {
            out.push('{');
            for (i, (key, item)) in map.iter().enumerate() {
                out.push_str(if i > 0 { ",\n" } else { "\n" });
                pad(out, depth + 1);
                let _ = write!(out, "{}: ", Value::String(key.clone()));
                write(out, item, depth + 1);
            }
            out.push('\n');
            pad(out, depth);
            out.push('}');
        }
        scalar => {
            let _ = write!(out, "{scalar}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_arrays_stay_on_one_line_and_the_text_parses_back() {
        let v = serde_json::json!({
            "name": "a \"quoted\" key",
            "rows": [[1.0, 0.5, -0.25], [0.1, 1e-300, 12345.678]],
            "lobes": [{"axis": [0.0, 1.0, 0.0], "sharpness": 2.5}],
            "empty": [],
            "none": {},
            "flag": true,
        });
        let t = text(&v);
        assert_eq!(serde_json::from_str::<Value>(&t).unwrap(), v);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines[0], "{");
        assert_eq!(lines[1], r#"  "name": "a \"quoted\" key","#);
        assert_eq!(lines[2], r#"  "rows": ["#);
        assert_eq!(lines[3], "    [1.0, 0.5, -0.25],");
        assert_eq!(lines[4], "    [0.1, 1e-300, 12345.678]");
        assert_eq!(lines[5], "  ],");
        assert_eq!(lines[8], r#"      "axis": [0.0, 1.0, 0.0],"#);
        assert!(t.contains("\"empty\": [],\n  \"none\": {},\n  \"flag\": true\n}\n"), "{t}");
    }
}
