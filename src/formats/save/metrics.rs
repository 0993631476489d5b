//! How `Save` writes [`Metrics`]: `.json` (one key per name, in order) or `.csv` (a header of the
//! names, then one row of the values).

use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::values::json::num;
use crate::values::{Metrics, METRICS};

/// Registers the saver of metrics.
pub fn register(r: &mut Registry) {
    r.register_saver(&METRICS, &["json", "csv"], save);
}

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let m = value.get::<Metrics>().ok_or("not metrics")?;
    Ok(match o.ext.as_str() {
        "csv" => csv(m),
        _ => {
            let mut map = serde_json::Map::new();
            for (name, v) in &m.fields {
                map.insert(name.clone(), num(*v));
            }
            serde_json::to_string_pretty(&serde_json::Value::Object(map)).expect("JSON of plain values") + "\n"
        }
    }
    .into_bytes())
}

/// One header line of the names, one line of the values (quoted where a name holds a comma, a
/// quote or a line break). No field gives two empty lines, as before the `csv` crate (which
/// would write `""`, a column of one empty name).
fn csv(m: &Metrics) -> String {
    if m.fields.is_empty() {
        return "\n\n".into();
    }
    let names = m.fields.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    let values = m.fields.iter().map(|(_, v)| v.to_string()).collect::<Vec<_>>();
    crate::formats::csv::text([names, values])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_is_a_header_of_names_and_one_row_of_values() {
        let m = Metrics { fields: vec![("rmse".into(), 0.25), ("psnr".into(), f64::INFINITY)] };
        assert_eq!(csv(&m), "rmse,psnr\n0.25,inf\n");
        let m = Metrics { fields: vec![("a,b".into(), 1.0)] };
        assert_eq!(csv(&m), "\"a,b\"\n1\n");
        assert_eq!(csv(&Metrics { fields: vec![] }), "\n\n");
    }
}
