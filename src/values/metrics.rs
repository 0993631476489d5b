//! `Metrics` (`metrics` in graphs): a flat record of named numbers (error metrics, statistics),
//! saved as `.json` or `.csv`.

use super::json::num;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{SaveOptions, TypeSpec, Value, ValueData, ValueType};

/// A flat record of named numbers, in the order they were added. Plain data, its field public:
/// each measuring operator pushes its own names.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Metrics {
    pub fields: Vec<(String, f64)>,
}

impl Metrics {
    pub fn get(&self, name: &str) -> Option<f64> {
        self.fields.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }
}

pub static METRICS: TypeSpec = TypeSpec {
    name: "metrics",
    doc: "a record of named numbers (errors, statistics)",
    decode,
    save_extensions: &["json", "csv"],
    save: Some(save),
};

impl ValueData for Metrics {
    fn value_type(&self) -> ValueType {
        ValueType(&METRICS)
    }
    fn approx_bytes(&self) -> usize {
        self.fields.len() * 32
    }
    fn display(&self) -> Option<String> {
        let width = self.fields.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
        Some(self.fields.iter().map(|(n, v)| format!("{n:<width$}  {v}")).collect::<Vec<_>>().join("\n"))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.fields.len() as u64);
        for (name, v) in &self.fields {
            w.str(name);
            w.f64(*v);
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let n = r.usize()?;
    r.need(n.saturating_mul(16))?;
    let mut fields = Vec::with_capacity(n);
    for _ in 0..n {
        fields.push((r.str()?, r.f64()?));
    }
    r.finish()?;
    Ok(Value::new(Metrics { fields }))
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
    super::csv::text([names, values])
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
