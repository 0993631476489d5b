//! The `curves` type of [`Curves`] and its cache payload: title, x name, x and y labels, the x
//! values, then each series (name, values), each scalar (name, present flag, value) and each
//! marker (label, x).

use super::Curves;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

pub static CURVES: TypeSpec = TypeSpec {
    name: "curves",
    doc: "named series over a shared x axis, with named scalars and marked abscissae",
    decode,
};

impl ValueData for Curves {
    fn value_type(&self) -> ValueType {
        ValueType(&CURVES)
    }
    fn approx_bytes(&self) -> usize {
        (self.x.len() * (1 + self.series.len())) * 8
    }
    fn display(&self) -> Option<String> {
        let mut lines = vec![format!(
            "{}: {} series ({}) over {} values of {}",
            self.title,
            self.series.len(),
            self.series.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", "),
            self.x.len(),
            self.x_name
        )];
        for (name, v) in &self.scalars {
            lines.push(match v {
                Some(v) => format!("{name}  {v}"),
                None => format!("{name}  none"),
            });
        }
        Some(lines.join("\n"))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.str(&self.title);
        w.str(&self.x_name);
        w.str(&self.x_label);
        w.str(&self.y_label);
        w.f64s(&self.x);
        w.u64(self.series.len() as u64);
        for (name, ys) in &self.series {
            w.str(name);
            w.f64s(ys);
        }
        w.u64(self.scalars.len() as u64);
        for (name, v) in &self.scalars {
            w.str(name);
            match v {
                Some(v) => {
                    w.u8(1);
                    w.f64(*v);
                }
                None => w.u8(0),
            }
        }
        w.u64(self.markers.len() as u64);
        for (label, x) in &self.markers {
            w.str(label);
            w.f64(*x);
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let title = r.str()?;
    let x_name = r.str()?;
    let x_label = r.str()?;
    let y_label = r.str()?;
    let x = r.f64s()?;
    let n = r.usize()?;
    r.need(n.saturating_mul(16))?;
    let mut series = Vec::with_capacity(n);
    for _ in 0..n {
        let s = (r.str()?, r.f64s()?);
        if s.1.len() != x.len() {
            return Err("a series' length differs from the abscissa's".into());
        }
        series.push(s);
    }
    let n = r.usize()?;
    r.need(n.saturating_mul(9))?;
    let mut scalars = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.str()?;
        let v = if r.u8()? == 1 { Some(r.f64()?) } else { None };
        scalars.push((name, v));
    }
    let n = r.usize()?;
    r.need(n.saturating_mul(16))?;
    let mut markers = Vec::with_capacity(n);
    for _ in 0..n {
        markers.push((r.str()?, r.f64()?));
    }
    r.finish()?;
    Ok(Value::new(Curves { title, x_name, x_label, y_label, x, series, scalars, markers }))
}
