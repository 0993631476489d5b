//! `Label` (`label` in graphs): what a dataset stores about one camera crop of an environment
//! map, as `CropLabel` gathers it: the crop's camera and, when given, the map's SH coefficients,
//! spherical Gaussian lobes and parametric lights. Saved as `.json`:
//!
//! ```text
//! {"camera": {"model", "fov", "width", "height", "yaw", "pitch", "roll", "world_to_camera"},
//!  "sh": {"frame", "order", "basis", "coefficients"},
//!  "spherical_gaussians": {"lobes": [{"axis", "sharpness", "amplitude"}, ...]},
//!  "lights": {"lights": [{"direction", "solid_angle", "radiance"}, ...], "ambient"}}
//! ```
//!
//! Each part is the JSON its own type saves (`camera`, `sh coefficients`, `sg`, `lights`), key
//! for key and number for number; a part whose input was not wired is left out. Arrays of
//! numbers stay on one line; numbers are the shortest decimal that reads back to the same f64.

use super::{camera, lights, sg, sh};
use super::{Camera, Lights, ShCoefficients, SphericalGaussians};
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// One crop's label. The lighting parts are in the frame of the map the crop was cut from
/// (hdrflow's world axes); `camera.world_to_camera()` takes a direction into the crop's camera
/// space.
/// Plain data, its fields public: `CropLabel` puts the parts together as they are.
#[derive(Clone, Debug, PartialEq)]
pub struct Label {
    pub camera: Camera,
    pub sh: Option<ShCoefficients>,
    pub sgs: Option<SphericalGaussians>,
    pub lights: Option<Lights>,
}

pub static LABEL: TypeSpec = TypeSpec {
    name: "label",
    doc: "a crop's label: its camera, and the map's SH coefficients, spherical Gaussians and lights when given",
    decode,
};

impl ValueData for Label {
    fn value_type(&self) -> ValueType {
        ValueType(&LABEL)
    }
    fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Label>()
            + self.sh.as_ref().map_or(0, |s| s.approx_bytes())
            + self.sgs.as_ref().map_or(0, |s| s.approx_bytes())
            + self.lights.as_ref().map_or(0, |l| l.approx_bytes())
    }
    fn summary(&self) -> String {
        let mut parts = vec![self.camera.summary()];
        parts.extend(self.sh.as_ref().map(|s| s.summary()));
        parts.extend(self.sgs.as_ref().map(|s| s.summary()));
        parts.extend(self.lights.as_ref().map(|l| l.summary()));
        format!("a label: {}", parts.join("; "))
    }
    fn display(&self) -> Option<String> {
        Some(to_json(self).trim_end().to_string())
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        camera::write_camera(&mut w, &self.camera);
        let parts: [Option<&dyn ValueData>; 3] = [
            self.sh.as_ref().map(|s| s as &dyn ValueData),
            self.sgs.as_ref().map(|s| s as &dyn ValueData),
            self.lights.as_ref().map(|l| l as &dyn ValueData),
        ];
        for part in parts {
            match part {
                None => w.u8(0),
                Some(v) => {
                    w.u8(1);
                    let mut payload = Vec::new();
                    v.encode(&mut payload);
                    w.bytes(&payload);
                }
            }
        }
    }
}

/// An optional part: a flag byte, then the part's own payload, read by its type's decoder.
fn read_part<T: ValueData + Clone>(r: &mut Reader, spec: &TypeSpec) -> Result<Option<T>, String> {
    match r.u8()? {
        0 => Ok(None),
        1 => {
            let value = (spec.decode)(r.bytes()?)?;
            value.get::<T>().cloned().map(Some).ok_or_else(|| format!("a label's {} part is not one", spec.name))
        }
        f => Err(format!("bad label part flag {f}")),
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let camera = camera::read_camera(&mut r)?;
    let sh = read_part::<ShCoefficients>(&mut r, &super::SH_COEFFICIENTS)?;
    let sgs = read_part::<SphericalGaussians>(&mut r, &super::SG)?;
    let lights = read_part::<Lights>(&mut r, &super::LIGHTS)?;
    r.finish()?;
    Ok(Value::new(Label { camera, sh, sgs, lights }))
}

/// The JSON object of a label (keys `camera`, then `sh`, `spherical_gaussians`, `lights` for
/// the parts it has).
pub fn to_json_value(l: &Label) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("camera".into(), camera::to_json_value(&l.camera));
    if let Some(s) = &l.sh {
        map.insert("sh".into(), sh::to_json_value(s));
    }
    if let Some(s) = &l.sgs {
        map.insert("spherical_gaussians".into(), sg::to_json_value(s));
    }
    if let Some(s) = &l.lights {
        map.insert("lights".into(), lights::to_json_value(s));
    }
    serde_json::Value::Object(map)
}

/// The JSON text of a label.
pub fn to_json(l: &Label) -> String {
    super::json::text(&to_json_value(l))
}

/// A label with every part, for the tests of its codec and of how `Save` writes it.
#[cfg(test)]
pub(crate) fn full_label_for_tests() -> Label {
    use crate::geometry::lens::Model;
    use crate::values::{Light, SgLobe, ShFrame};
    Label {
        camera: Camera { model: Model::Perspective, fov: 60.0, width: 4, height: 3, yaw: 45.0, pitch: 5.0, roll: 0.0 },
        sh: Some(ShCoefficients { order: 1, frame: ShFrame::World, rgb: vec![[1.0, 2.0, 3.0]; 4] }),
        sgs: Some(SphericalGaussians {
            lobes: vec![SgLobe { axis: [0.0, 1.0, 0.0], sharpness: 3.5, amplitude: [0.5, 0.25, 0.125] }],
        }),
        lights: Some(Lights {
            lights: vec![Light { direction: [0.0, 0.6, -0.8], solid_angle: 1e-3, radiance: [5e4, 4e4, 3e4] }],
            ambient: [0.1, 0.2, 0.3],
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_combination_of_parts_round_trips_through_the_cache_payload() {
        let f = full_label_for_tests();
        for mask in 0..8u8 {
            let l = Label {
                camera: f.camera,
                sh: f.sh.clone().filter(|_| mask & 1 != 0),
                sgs: f.sgs.clone().filter(|_| mask & 2 != 0),
                lights: f.lights.clone().filter(|_| mask & 4 != 0),
            };
            let mut bytes = Vec::new();
            l.encode(&mut bytes);
            assert_eq!(decode(&bytes).unwrap().get::<Label>(), Some(&l), "parts {mask:03b}");
            let e = decode(&bytes[..bytes.len() - 1]).unwrap_err();
            assert!(e.contains("truncated: need"), "parts {mask:03b}: {e}");
            let json: serde_json::Value = serde_json::from_str(&to_json(&l)).unwrap();
            let keys: Vec<&String> = json.as_object().unwrap().keys().collect();
            let want: Vec<&str> = [(0, "camera"), (1, "sh"), (2, "spherical_gaussians"), (4, "lights")]
                .into_iter()
                .filter(|&(bit, _)| bit == 0 || mask & bit != 0)
                .map(|(_, k)| k)
                .collect();
            assert_eq!(keys, want);
        }
        // A bad flag byte is an error, not a guess.
        let mut bytes = Vec::new();
        camera::write_camera(&mut Writer(&mut bytes), &f.camera);
        bytes.push(7);
        assert!(decode(&bytes).unwrap_err().contains("flag 7"));
    }
}
