//! `Lights` (`lights` in graphs): a few parametric lights and an ambient colour, as
//! `ExtractLights` takes them out of an environment map (the parametric model of
//! lighting-estimation papers). Saved as `.json`: `{"lights": [{"direction": [x, y, z],
//! "solid_angle": sr, "radiance": [r, g, b]}, ...], "ambient": [r, g, b]}` (each light with the
//! keys of a `light`; numbers as the shortest decimal that reads back to the same f64; NaN and
//! Inf, which `ExtractLights` never produces, become `null`).

use std::f64::consts::PI;

use super::light::{json_triple, read_light, to_json_value as light_json_value, write_light, LIGHT_BYTES};
use super::Light;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// An environment approximated as a constant `ambient` radiance over the whole sphere plus
/// `lights`, each adding its `radiance` over its `solid_angle` around its `direction`. Its
/// integral is `sum_i radiance_i solid_angle_i + ambient 4 pi` per channel ([`Lights::power`]),
/// which `ExtractLights` makes equal to the map's.
/// Plain data, its fields public (the lights and the ambient colour are the model).
#[derive(Clone, Debug, PartialEq)]
pub struct Lights {
    /// The lights, most energetic first.
    pub lights: Vec<Light>,
    /// The ambient radiance (RGB), over the whole sphere (4 pi sr).
    pub ambient: [f64; 3],
}

impl Lights {
    /// `sum_i radiance_i solid_angle_i + ambient 4 pi`, per channel: the model's integral over
    /// the sphere.
    pub fn power(&self) -> [f64; 3] {
        let mut p = self.ambient.map(|a| a * 4.0 * PI);
        for l in &self.lights {
            for (pc, lc) in p.iter_mut().zip(l.power()) {
                *pc += lc;
            }
        }
        p
    }
}

pub static LIGHTS: TypeSpec = TypeSpec {
    name: "lights",
    doc: "parametric lights (each a direction, solid angle, RGB radiance) plus an ambient RGB radiance",
    decode,
};

impl ValueData for Lights {
    fn value_type(&self) -> ValueType {
        ValueType(&LIGHTS)
    }
    fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Lights>() + self.lights.len() * std::mem::size_of::<Light>()
    }
    fn summary(&self) -> String {
        let [r, g, b] = self.ambient;
        format!("{} lights and an ambient of ({r:.4e}, {g:.4e}, {b:.4e})", self.lights.len())
    }
    fn display(&self) -> Option<String> {
        let mut lines = Vec::new();
        for (i, l) in self.lights.iter().enumerate() {
            let [x, y, z] = l.direction;
            let [r, g, b] = l.radiance;
            lines.push(format!(
                "light {i}: direction ({x}, {y}, {z}), solid_angle {}, radiance ({r}, {g}, {b})",
                l.solid_angle
            ));
        }
        let [r, g, b] = self.ambient;
        lines.push(format!("ambient ({r}, {g}, {b})"));
        Some(lines.join("\n"))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.lights.len() as u64);
        for l in &self.lights {
            write_light(&mut w, l);
        }
        for v in self.ambient {
            w.f64(v);
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let n = r.usize()?;
    r.need(n.saturating_mul(LIGHT_BYTES).saturating_add(3 * 8))?;
    let lights = (0..n).map(|_| read_light(&mut r)).collect::<Result<Vec<_>, _>>()?;
    let ambient = [r.f64()?, r.f64()?, r.f64()?];
    r.finish()?;
    Ok(Value::new(Lights { lights, ambient }))
}

/// The JSON text of lights (keys `lights`, each with `direction`, `solid_angle`, `radiance`, and
/// `ambient`).
pub fn to_json(l: &Lights) -> String {
    serde_json::to_string_pretty(&to_json_value(l)).expect("JSON of plain values") + "\n"
}

/// The JSON object of lights (as in [`to_json`] and a label's `lights`).
pub fn to_json_value(l: &Lights) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("lights".into(), serde_json::Value::Array(l.lights.iter().map(light_json_value).collect()));
    map.insert("ambient".into(), json_triple(l.ambient));
    serde_json::Value::Object(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_saves_json() {
        let l = Lights {
            lights: vec![
                Light { direction: [0.0, 0.6, -0.8], solid_angle: 1e-3, radiance: [5e4, 4.5e4, 3.8e4] },
                Light { direction: [1.0, 0.0, 0.0], solid_angle: 0.25, radiance: [2.0, 0.0, 1.5] },
            ],
            ambient: [0.1, 0.2, 0.3],
        };
        let mut bytes = Vec::new();
        l.encode(&mut bytes);
        assert_eq!(decode(&bytes).unwrap().get::<Lights>(), Some(&l));
        let e = decode(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.starts_with("truncated: need"), "{e}");
        // A hostile count is refused before allocating.
        let mut huge = Vec::new();
        Writer(&mut huge).u64(u64::MAX / 2);
        let e = decode(&huge).unwrap_err();
        assert!(e.starts_with("truncated: need") && e.ends_with("0 left"), "{e}");
        let json: serde_json::Value = serde_json::from_str(&to_json(&l)).unwrap();
        assert_eq!(json.as_object().unwrap().len(), 2);
        assert_eq!(json["ambient"][2].as_f64(), Some(0.3));
        let lights = json["lights"].as_array().unwrap();
        assert_eq!(lights.len(), 2);
        assert_eq!(lights[0]["solid_angle"].as_f64(), Some(1e-3));
        assert_eq!(lights[0]["direction"][2].as_f64(), Some(-0.8));
        assert_eq!(lights[1]["radiance"][2].as_f64(), Some(1.5));
        assert_eq!(lights[1].as_object().unwrap().len(), 3);
        // No lights: an empty list.
        let none = Lights { lights: Vec::new(), ambient: [1.0; 3] };
        let json: serde_json::Value = serde_json::from_str(&to_json(&none)).unwrap();
        assert_eq!(json["lights"].as_array().map(Vec::len), Some(0));
    }
}
