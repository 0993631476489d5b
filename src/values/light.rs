//! `Light` (`light` in graphs): a distant light of small solid angle (a sun), as `SunExtract`
//! takes it out of an environment map. Saved as `.json`: `{"direction": [x, y, z], "solid_angle":
//! sr, "radiance": [r, g, b]}` (numbers as the shortest decimal that reads back to the same f64;
//! NaN and Inf, which `SunExtract` never produces, become `null`).

use super::json::num;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// A distant light: every direction within `solid_angle` steradians around `direction` carries
/// radiance `radiance` (RGB, the map's units). Its irradiance on a surface facing it is
/// `radiance * solid_angle` (for a small solid angle); `radiance * solid_angle` is also exactly
/// what `SunExtract` removed from the map's integral.
/// Plain data, its fields public (direction, solid angle and radiance are the light).
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Unit direction towards the light (hdrflow's world axes: +Y up, see `geometry::latlong`).
    pub direction: [f64; 3],
    /// Solid angle in steradians (0 for "no light").
    pub solid_angle: f64,
    /// Radiance per channel (RGB); all 0 for "no light".
    pub radiance: [f64; 3],
}

impl Light {
    /// No light: zero radiance and solid angle, pointing at `direction`.
    pub fn none(direction: [f64; 3]) -> Light {
        Light { direction, solid_angle: 0.0, radiance: [0.0; 3] }
    }

    /// `radiance * solid_angle` per channel: the light's share of the map's integral.
    pub fn power(&self) -> [f64; 3] {
        self.radiance.map(|l| l * self.solid_angle)
    }
}

pub static LIGHT: TypeSpec =
    TypeSpec { name: "light", doc: "a distant light: unit direction, solid angle (sr), RGB radiance", decode };

impl ValueData for Light {
    fn value_type(&self) -> ValueType {
        ValueType(&LIGHT)
    }
    fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Light>()
    }
    fn summary(&self) -> String {
        let [x, y, z] = self.direction;
        format!("a light towards ({x:.4}, {y:.4}, {z:.4}) of {:.3e} sr", self.solid_angle)
    }
    fn display(&self) -> Option<String> {
        let [x, y, z] = self.direction;
        let [r, g, b] = self.radiance;
        Some(format!("direction    ({x}, {y}, {z})\nsolid_angle  {}\nradiance     ({r}, {g}, {b})", self.solid_angle))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        write_light(&mut Writer(out), self);
    }
}

/// The bytes of one light in a cache payload: direction, solid angle, radiance (7 f64).
pub(crate) const LIGHT_BYTES: usize = 7 * 8;

/// Writes one light's [`LIGHT_BYTES`] (a `light` payload, and each entry of a `lights` one).
pub(crate) fn write_light(w: &mut Writer, l: &Light) {
    for v in l.direction.iter().chain([l.solid_angle].iter()).chain(l.radiance.iter()) {
        w.f64(*v);
    }
}

/// Reads what [`write_light`] wrote.
pub(crate) fn read_light(r: &mut Reader) -> Result<Light, String> {
    let direction = [r.f64()?, r.f64()?, r.f64()?];
    let solid_angle = r.f64()?;
    let radiance = [r.f64()?, r.f64()?, r.f64()?];
    Ok(Light { direction, solid_angle, radiance })
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    r.need(LIGHT_BYTES)?;
    let light = read_light(&mut r)?;
    r.finish()?;
    Ok(Value::new(light))
}

/// A JSON array of three numbers.
pub(crate) fn json_triple(v: [f64; 3]) -> serde_json::Value {
    serde_json::Value::Array(v.iter().map(|&x| num(x)).collect())
}

/// The JSON object of a light (keys `direction`, `solid_angle`, `radiance`).
pub(crate) fn to_json_value(l: &Light) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("direction".into(), json_triple(l.direction));
    map.insert("solid_angle".into(), num(l.solid_angle));
    map.insert("radiance".into(), json_triple(l.radiance));
    serde_json::Value::Object(map)
}

/// The JSON text of a light (keys `direction`, `solid_angle`, `radiance`).
pub fn to_json(l: &Light) -> String {
    serde_json::to_string_pretty(&to_json_value(l)).expect("JSON of plain values") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_saves_json() {
        let l = Light { direction: [0.0, 0.6, -0.8], solid_angle: 1e-3, radiance: [5e4, 4.5e4, 3.8e4] };
        let mut bytes = Vec::new();
        l.encode(&mut bytes);
        let back = decode(&bytes).unwrap();
        assert_eq!(back.get::<Light>(), Some(&l));
        let e = decode(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.starts_with("truncated: need"), "{e}");
        let json: serde_json::Value = serde_json::from_str(&to_json(&l)).unwrap();
        assert_eq!(json["solid_angle"].as_f64(), Some(1e-3));
        assert_eq!(json["direction"][2].as_f64(), Some(-0.8));
        assert_eq!(json["radiance"][0].as_f64(), Some(5e4));
        assert_eq!(json.as_object().unwrap().len(), 3);
    }
}
