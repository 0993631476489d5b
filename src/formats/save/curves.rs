//! How `Save` writes [`Curves`]: `.json` (the scalars, then each column), `.csv` (one header,
//! one row per x, the scalars as columns) or a plot (`.png`, `.svg`, `crate::plotting`).

use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::values::json::num;
use crate::values::{Curves, CURVES};

/// Registers the saver of curves.
pub fn register(r: &mut Registry) {
    r.register_saver(&CURVES, &["json", "csv", "png", "svg"], save);
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
    crate::formats::csv::text(std::iter::once(header).chain(rows))
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
