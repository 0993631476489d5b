//! `Metrics` (`metrics` in graphs): a flat record of named numbers (error metrics, statistics),
//! saved as `.json` or `.csv` (`crate::formats::save::metrics`).

use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

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

pub static METRICS: TypeSpec =
    TypeSpec { name: "metrics", doc: "a record of named numbers (errors, statistics)", decode };

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
