//! `SphericalGaussians` (`sg` in graphs): an environment approximated as a sum of spherical
//! Gaussian lobes, as `SphericalGaussians` fits them (the compact lighting model of Wang et al.,
//! "All-frequency rendering of dynamic, spatially-varying reflectance", SIGGRAPH Asia 2009, and of
//! the lighting-estimation papers that followed).
//!
//! Saved as `.json`: `{"lobes": [{"axis": [x, y, z], "sharpness": lambda, "amplitude": [r, g,
//! b]}, ...]}` (each lobe `amplitude exp(sharpness (axis . d - 1))`; numbers as the shortest
//! decimal that reads back to the same f64; NaN and Inf, which the fit never produces, become
//! `null`).

use std::f64::consts::PI;

use glam::DVec3;

use super::json::num;
use super::light::json_triple;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// One lobe, `L(d) = amplitude exp(sharpness (axis . d - 1))`: its peak `amplitude` (RGB, the
/// map's units) is at `axis`, and it falls to `1/e` at the angle `acos(1 - 1/sharpness)`
/// (about `1 / sqrt(sharpness)` radians for a sharp lobe).
/// Plain data, its fields public (axis, sharpness and amplitude are the lobe).
#[derive(Clone, Debug, PartialEq)]
pub struct SgLobe {
    /// Unit direction of the peak (hdrflow's world axes: +Y up, see `geometry::latlong`).
    pub axis: [f64; 3],
    /// `lambda > 0`: the larger, the narrower.
    pub sharpness: f64,
    /// The peak radiance per channel (RGB).
    pub amplitude: [f64; 3],
}

impl SgLobe {
    /// `exp(lambda (axis . d - 1))`, in (0, 1] for a unit `d`.
    #[inline]
    pub fn kernel(&self, d: [f64; 3]) -> f64 {
        (self.sharpness * (DVec3::from(self.axis).dot(DVec3::from(d)) - 1.0)).exp()
    }

    /// `L(d)` per channel.
    pub fn value(&self, d: [f64; 3]) -> [f64; 3] {
        let g = self.kernel(d);
        self.amplitude.map(|a| a * g)
    }

    /// The lobe's integral over the sphere per channel, in closed form:
    /// `int exp(lambda (cos t - 1)) dw = 2 pi int_{-1}^{1} exp(lambda (u - 1)) du
    /// = 2 pi (1 - exp(-2 lambda)) / lambda` (written with `expm1`, exact to rounding for any
    /// lambda; 4 pi in the limit lambda -> 0).
    pub fn integral(&self) -> [f64; 3] {
        let l = self.sharpness;
        let solid = if l > 0.0 { 2.0 * PI * -(-2.0 * l).exp_m1() / l } else { 4.0 * PI };
        self.amplitude.map(|a| a * solid)
    }
}

/// A sum of lobes: `L(d) = sum_k L_k(d)`.
/// Plain data, its field public: the fit writes the lobes, the renderers read them.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SphericalGaussians {
    /// The lobes, most energetic first when `SphericalGaussians` fitted them.
    pub lobes: Vec<SgLobe>,
}

impl SphericalGaussians {
    /// `L(d)` per channel.
    pub fn value(&self, d: [f64; 3]) -> [f64; 3] {
        value_of(&self.lobes, d)
    }

    /// The integral over the sphere per channel (the sum of the lobes' closed forms).
    pub fn integral(&self) -> [f64; 3] {
        sum_of(self.lobes.iter().map(SgLobe::integral))
    }
}

/// `L(d) = sum_k L_k(d)` per channel, the lobes added in order.
pub fn value_of(lobes: &[SgLobe], d: [f64; 3]) -> [f64; 3] {
    sum_of(lobes.iter().map(|l| l.value(d)))
}

/// The per-channel sum of RGB triples, in order.
fn sum_of(items: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    items.fold([0.0; 3], |s, v| [s[0] + v[0], s[1] + v[1], s[2] + v[2]])
}

pub static SG: TypeSpec =
    TypeSpec { name: "sg", doc: "spherical Gaussian lobes (each a unit axis, a sharpness, an RGB amplitude)", decode };

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
