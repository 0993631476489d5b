//! `sg`: spherical Gaussian lobes ([`SphericalGaussians`]), as `SphericalGaussians` fits them.
//! Saved as `.json`: `{"lobes": [{"axis": [x, y, z], "sharpness": lambda, "amplitude": [r, g,
//! b]}, ...]}` (each lobe `amplitude exp(sharpness (axis . d - 1))`; numbers as the shortest
//! decimal that reads back to the same f64; NaN and Inf, which the fit never produces, become
//! `null`).

use super::json_num as num;
use super::light::json_triple;
use crate::data::{SgLobe, SphericalGaussians};
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{SaveOptions, TypeSpec, Value, ValueData, ValueType};

pub static SG: TypeSpec = TypeSpec {
    name: "sg",
    doc: "spherical Gaussian lobes (each a unit axis, a sharpness, an RGB amplitude)",
    decode,
    save_extensions: &["json"],
    save: Some(save),
};

/// The bytes of one lobe in a cache payload: axis, sharpness, amplitude (7 f64).
const LOBE_BYTES: usize = 7 * 8;

impl ValueData for SphericalGaussians {
    fn value_type(&self) -> ValueType {
        ValueType(&SG)
    }
    fn approx_bytes(&self) -> usize {
        std::mem::size_of::<SphericalGaussians>() + self.lobes.len() * std::mem::size_of::<SgLobe>()
    }
    fn summary(&self) -> String {
        format!("{} spherical Gaussian lobes", self.lobes.len())
    }
    fn display(&self) -> Option<String> {
        let lines: Vec<String> = self
            .lobes
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let [x, y, z] = l.axis;
                let [r, g, b] = l.amplitude;
                format!("lobe {i}: axis ({x}, {y}, {z}), sharpness {}, amplitude ({r}, {g}, {b})", l.sharpness)
            })
            .collect();
        Some(lines.join("\n"))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.lobes.len() as u64);
        for l in &self.lobes {
            for v in l.axis.iter().chain([l.sharpness].iter()).chain(l.amplitude.iter()) {
                w.f64(*v);
            }
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let n = r.usize()?;
    r.need(n.saturating_mul(LOBE_BYTES))?;
    let mut lobes = Vec::with_capacity(n);
    for _ in 0..n {
        let axis = [r.f64()?, r.f64()?, r.f64()?];
        let sharpness = r.f64()?;
        let amplitude = [r.f64()?, r.f64()?, r.f64()?];
        lobes.push(SgLobe { axis, sharpness, amplitude });
    }
    r.finish()?;
    Ok(Value::new(SphericalGaussians { lobes }))
}

/// The JSON text of the lobes: `{"lobes": [{"axis", "sharpness", "amplitude"}, ...]}`.
pub fn to_json(sg: &SphericalGaussians) -> String {
    serde_json::to_string_pretty(&to_json_value(sg)).expect("JSON of plain values") + "\n"
}

/// The JSON object of the lobes (as in [`to_json`] and a label's `spherical_gaussians`).
pub fn to_json_value(sg: &SphericalGaussians) -> serde_json::Value {
    let lobes = sg
        .lobes
        .iter()
        .map(|l| {
            let mut map = serde_json::Map::new();
            map.insert("axis".into(), json_triple(l.axis));
            map.insert("sharpness".into(), num(l.sharpness));
            map.insert("amplitude".into(), json_triple(l.amplitude));
            serde_json::Value::Object(map)
        })
        .collect();
    let mut map = serde_json::Map::new();
    map.insert("lobes".into(), serde_json::Value::Array(lobes));
    serde_json::Value::Object(map)
}

fn save(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let sg = value.get::<SphericalGaussians>().ok_or("not spherical Gaussians")?;
    Ok(to_json(sg).into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_saves_json() {
        let sg = SphericalGaussians {
            lobes: vec![
                SgLobe { axis: [0.0, 0.6, -0.8], sharpness: 250.5, amplitude: [5e4, 4.5e4, 3.8e4] },
                SgLobe { axis: [1.0, 0.0, 0.0], sharpness: 0.75, amplitude: [2.0, 0.0, 1.5] },
            ],
        };
        let mut bytes = Vec::new();
        sg.encode(&mut bytes);
        assert_eq!(bytes.len(), 8 + 2 * LOBE_BYTES);
        assert_eq!(decode(&bytes).unwrap().get::<SphericalGaussians>(), Some(&sg));
        let e = decode(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.starts_with("truncated: need"), "{e}");
        // A hostile count is refused before allocating.
        let mut huge = Vec::new();
        Writer(&mut huge).u64(u64::MAX / 2);
        let e = decode(&huge).unwrap_err();
        assert!(e.starts_with("truncated: need") && e.ends_with("0 left"), "{e}");
        let json: serde_json::Value = serde_json::from_str(&to_json(&sg)).unwrap();
        assert_eq!(json.as_object().unwrap().keys().collect::<Vec<_>>(), ["lobes"]);
        let lobes = json["lobes"].as_array().unwrap();
        assert_eq!(lobes.len(), 2);
        assert_eq!(lobes[0].as_object().unwrap().keys().collect::<Vec<_>>(), ["axis", "sharpness", "amplitude"]);
        assert_eq!(lobes[0]["sharpness"].as_f64(), Some(250.5));
        assert_eq!(lobes[0]["axis"][2].as_f64(), Some(-0.8));
        assert_eq!(lobes[1]["amplitude"][2].as_f64(), Some(1.5));
        // No lobes: an empty list.
        let json: serde_json::Value = serde_json::from_str(&to_json(&SphericalGaussians::default())).unwrap();
        assert_eq!(json["lobes"].as_array().map(Vec::len), Some(0));
    }
}
