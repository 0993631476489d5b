//! `curves`: named series over a shared abscissa ([`Curves`]). Saved as `.json`, `.csv`, or a
//! plot (`.png`, `.svg`).

use super::csv_text;
use super::json_num as num;
use crate::data::Curves;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{SaveOptions, TypeSpec, Value, ValueData, ValueType};

pub static CURVES: TypeSpec = TypeSpec {
    name: "curves",
    doc: "named series over a shared x axis, with named scalars and marked abscissae",
    decode,
    save_extensions: &["json", "csv", "png", "svg"],
    save: Some(save),
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

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<Curves>().ok_or("not curves")?;
    let (w, h) = o.plot_size;
    Ok(match o.ext.as_str() {
        "json" => curves_json(c).into_bytes(),
        "csv" => curves_csv(c).into_bytes(),
        "svg" => crate::plotting::curves_plot::plot_svg(c, w, h)?.into_bytes(),
        _ => crate::plotting::curves_plot::plot_png(c, w, h)?,
    })
}

fn curves_json(c: &Curves) -> String {
    let mut map = serde_json::Map::new();
    for (name, v) in &c.scalars {
        map.insert(name.clone(), v.map(num).unwrap_or(serde_json::Value::Null));
    }
    map.insert(c.x_name.clone(), c.x.iter().map(|&v| num(v)).collect());
    for (name, ys) in &c.series {
        map.insert(name.clone(), ys.iter().map(|&v| num(v)).collect());
    }
    serde_json::to_string_pretty(&serde_json::Value::Object(map)).expect("JSON of plain values") + "\n"
}

/// Curves as plain CSV, one header line then one row per x, which any CSV reader takes as it is
/// (no comment lines). The named scalars (e.g. the Brewster and critical angles) are columns of
/// their own after the series, their value on every row (empty where there is none). Names are
/// quoted where they hold a comma, a quote or a line break (RFC 4180).
fn curves_csv(c: &Curves) -> String {
    let header: Vec<String> = std::iter::once(c.x_name.clone())
        .chain(c.series.iter().map(|(name, _)| name.clone()))
        .chain(c.scalars.iter().map(|(name, _)| name.clone()))
        .collect();
    let scalars: Vec<String> = c.scalars.iter().map(|(_, v)| v.map(|v| v.to_string()).unwrap_or_default()).collect();
    let rows = c.x.iter().enumerate().map(|(i, x)| {
        std::iter::once(x.to_string())
            .chain(c.series.iter().map(|(_, ys)| ys[i].to_string()))
            .chain(scalars.iter().cloned())
            .collect::<Vec<_>>()
    });
    csv_text(std::iter::once(header).chain(rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_has_one_plain_header_and_scalars_as_columns() {
        let c = Curves {
            title: "t".into(),
            x_name: "angle".into(),
            x_label: String::new(),
            y_label: String::new(),
            x: vec![0.0, 1.0],
            series: vec![("R".into(), vec![0.5, 0.25])],
            scalars: vec![("brewster".into(), Some(56.3)), ("critical".into(), None)],
            markers: vec![],
        };
        assert_eq!(curves_csv(&c), "angle,R,brewster,critical\n0,0.5,56.3,\n1,0.25,56.3,\n");
    }

    #[test]
    fn csv_quotes_names_that_hold_a_comma_or_a_quote() {
        let c = Curves {
            title: "t".into(),
            x_name: "angle, degrees".into(),
            x_label: String::new(),
            y_label: String::new(),
            x: vec![0.0],
            series: vec![("R \"s\"".into(), vec![0.5])],
            scalars: vec![],
            markers: vec![],
        };
        assert_eq!(curves_csv(&c), "\"angle, degrees\",\"R \"\"s\"\"\"\n0,0.5\n");
    }
}
