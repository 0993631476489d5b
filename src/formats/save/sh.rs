//! How `Save` writes spherical harmonics.
//!
//! `sh coefficients` ([`ShCoefficients`]), as `values::sh` declares them:
//!
//! - `.json`: `{"frame": "World", "order": 2, "basis": "<the convention and axes, one line>",
//!   "coefficients": [[r, g, b], ...]}`, `(order + 1)^2` rows in `(l, m)` order (l = 0..=order,
//!   m = -l..=l), one row per line (`values::sh::to_json_value`, also a label's `sh`). Numbers
//!   are written as the shortest decimal that reads back to the same f64 (an exact parser, such
//!   as Python's, gets the bits back); NaN and Inf become `null`.
//! - `.csv`: the header `l,m,r,g,b,frame`, then one row per coefficient. The frame is a column
//!   (the same on every row) rather than a comment line, so that the file stays plain CSV and a
//!   copy that travels without its JSON still says which axes its numbers belong to.
//!
//! `filament sh` ([`FilamentSh`]): `.txt`, cmgen's `sh.txt` (`values::filament_sh::sh_txt`, its
//! layout documented there), or `.json`: `{"form": "...", "coefficients": [[r, g, b] x 9]}`,
//! shortest round-trip numbers.

use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::values::filament_sh::sh_txt;
use crate::values::json::num;
use crate::values::sh::to_json_value;
use crate::values::{FilamentSh, ShCoefficients, FILAMENT_SH, SH_COEFFICIENTS};

/// Registers the savers of SH coefficients and of Filament's SH.
pub fn register(r: &mut Registry) {
    r.register_saver(&SH_COEFFICIENTS, &["json", "csv"], save);
    r.register_saver(&FILAMENT_SH, &["txt", "json"], save_filament);
}

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<ShCoefficients>().ok_or("not SH coefficients")?;
    Ok(match o.ext.as_str() {
        "csv" => csv(c),
        _ => json(c),
    }
    .into_bytes())
}

/// The JSON text, one coefficient row per line.
fn json(c: &ShCoefficients) -> String {
    crate::values::json::text(&to_json_value(c))
}

fn csv(c: &ShCoefficients) -> String {
    let header = ["l", "m", "r", "g", "b", "frame"].map(String::from);
    let rows = c.iter().map(|(l, m, v)| {
        [l.to_string(), m.to_string(), v[0].to_string(), v[1].to_string(), v[2].to_string(), c.frame.name().into()]
    });
    crate::formats::csv::text(std::iter::once(header).chain(rows))
}

/// One line of the JSON: what the numbers are.
const FORM: &str = "Filament pre-scaled irradiance / pi: sh0 + sh1 y + sh2 z + sh3 x + sh4 yx + sh5 yz + \
                    sh6 (3z^2 - 1) + sh7 zx + sh8 (x^2 - y^2), world normal (x, y, z)";

fn save_filament(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let sh = value.get::<FilamentSh>().ok_or("not Filament SH")?;
    Ok(match o.ext.as_str() {
        "txt" => sh_txt(sh),
        _ => {
            let mut map = serde_json::Map::new();
            map.insert("form".into(), FORM.into());
            let rows = sh.rgb.iter().map(|v| serde_json::Value::Array(v.iter().map(|&x| num(x)).collect())).collect();
            map.insert("coefficients".into(), serde_json::Value::Array(rows));
            crate::values::json::text(&serde_json::Value::Object(map))
        }
    }
    .into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::ShFrame;

    fn sample() -> ShCoefficients {
        let rgb = (0..9).map(|i| [i as f64 * 0.5 - 1.0, 1e-9 * i as f64, 12345.678 / (i + 1) as f64]).collect();
        ShCoefficients { order: 2, frame: ShFrame::World, rgb }
    }

    fn filament_sample() -> FilamentSh {
        let mut rgb = [[0.0; 3]; 9];
        for (i, c) in rgb.iter_mut().enumerate() {
            *c = [0.712845027446747 - i as f64 * 0.1, 0.0 - 0.25 * i as f64, 12.5 / (i + 1) as f64];
        }
        FilamentSh { rgb }
    }

    #[test]
    fn sh_coefficients_save_as_json_and_csv() {
        let c = sample();
        let json: serde_json::Value = serde_json::from_str(&super::json(&c)).unwrap();
        assert_eq!(json["frame"], "World");
        assert_eq!(json["order"], 2);
        assert_eq!(json["basis"], ShFrame::World.basis());
        assert_eq!(json["coefficients"].as_array().unwrap().len(), 9);
        // Shortest round-trip numbers, one row per line: an exact parser reads them back bit for
        // bit (serde_json's default float parser is not one, so parse the text here).
        let text = super::json(&c);
        let rows: Vec<Vec<f64>> = text
            .lines()
            .filter_map(|l| l.trim().strip_prefix('['))
            .map(|l| l.trim_end_matches(',').trim_end_matches(']').split(", ").map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows, c.rgb.iter().map(|v| v.to_vec()).collect::<Vec<_>>());
        let keys: Vec<&String> = json.as_object().unwrap().keys().collect();
        assert_eq!(keys, ["frame", "order", "basis", "coefficients"]);

        let csv = super::csv(&c);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "l,m,r,g,b,frame");
        assert_eq!(lines.len(), 10);
        assert_eq!(lines[2], format!("1,-1,{},{},{},World", c.rgb[1][0], c.rgb[1][1], c.rgb[1][2]));
        assert!(lines[9].starts_with("2,2,"));

        // An empty set of coefficients (never produced, but valid JSON all the same).
        let empty = ShCoefficients { order: 0, frame: ShFrame::Paper, rgb: vec![] };
        assert!(serde_json::from_str::<serde_json::Value>(&super::json(&empty)).is_ok());
    }

    #[test]
    fn filament_sh_saves_as_json() {
        let sh = filament_sample();
        let json = save_filament(&Value::new(sh), &SaveOptions::new("json")).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!(v["coefficients"].as_array().unwrap().len(), 9);
        assert_eq!(v["coefficients"][2][2].as_f64(), Some(12.5 / 3.0));
    }
}
