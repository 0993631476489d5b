//! `Camera` (`camera` in graphs): the camera of a view cut out of an environment map, as
//! `Project` declares it (its lens and its rotation) and gives it on its `camera` port, so that
//! what is written about a crop cannot drift from the crop.
//!
//! Saved as `.json`: `{"model": "Perspective", "fov": deg, "width": px, "height": px, "yaw": deg,
//! "pitch": deg, "roll": deg, "world_to_camera": [[m00, m01, m02], [m10, m11, m12], [m20, m21,
//! m22]]}` (the matrix row-major, `R^T` for the view's rotation `R`: it maps the view's centre
//! ray to (0, 0, -1); numbers as the shortest decimal that reads back to the same f64).

use glam::DVec3;

use super::json::num;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};
use crate::geometry::lens::Model;
use crate::geometry::rotation::Rotation;

/// A `width x height` view through a lens of `model` and horizontal field of view `fov`
/// (degrees), turned by `yaw`, `pitch`, `roll` (degrees, `Rotate`'s angles:
/// `R = R_y(yaw) R_x(pitch) R_z(roll)`). Camera space looks down -Z with +Y up and +X right, and
/// the view sees world direction `R c` for camera ray `c` (`geometry::lens`).
/// Plain data, its fields public: `Project` declares the camera it renders with, field by field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub model: Model,
    pub fov: f64,
    pub width: usize,
    pub height: usize,
    pub yaw: f64,
    pub pitch: f64,
    pub roll: f64,
}

impl Camera {
    /// `R`, camera to world: the rotation `Project` turns every camera ray by.
    pub fn rotation(&self) -> Rotation {
        Rotation::from_yaw_pitch_roll(self.yaw, self.pitch, self.roll)
    }

    /// `R^T`, world to camera, row-major (`[row][column]`): it maps a world direction `d` to
    /// the camera-space direction `R^T d`, so the view's centre ray goes to (0, 0, -1) and a
    /// light's world direction to where the camera sees it.
    pub fn world_to_camera(&self) -> [[f64; 3]; 3] {
        // Row i of R^T is column i of R.
        let m = self.rotation().0;
        [m.x_axis, m.y_axis, m.z_axis].map(|c| c.to_array())
    }

    /// The world direction the view's centre looks along, `R (0, 0, -1)`.
    pub fn forward(&self) -> DVec3 {
        self.rotation().apply(DVec3::NEG_Z)
    }
}

pub static CAMERA: TypeSpec = TypeSpec {
    name: "camera",
    doc: "a view's camera: lens model, horizontal fov, size, yaw/pitch/roll and the world-to-camera matrix",
    decode,
};

impl ValueData for Camera {
    fn value_type(&self) -> ValueType {
        ValueType(&CAMERA)
    }
    fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Camera>()
    }
    fn summary(&self) -> String {
        format!(
            "a {} x {} {} camera of fov {} at yaw {}, pitch {}, roll {}",
            self.width, self.height, self.model, self.fov, self.yaw, self.pitch, self.roll
        )
    }
    fn display(&self) -> Option<String> {
        Some(super::json::text(&to_json_value(self)).trim_end().to_string())
    }
    fn encode(&self, out: &mut Vec<u8>) {
        write_camera(&mut Writer(out), self);
    }
}

/// Writes a camera's payload (its own, and the first part of a `label`'s).
pub(crate) fn write_camera(w: &mut Writer, c: &Camera) {
    w.str(c.model.name());
    w.f64(c.fov);
    w.u64(c.width as u64);
    w.u64(c.height as u64);
    for v in [c.yaw, c.pitch, c.roll] {
        w.f64(v);
    }
}

/// Reads what [`write_camera`] wrote.
pub(crate) fn read_camera(r: &mut Reader) -> Result<Camera, String> {
    let name = r.str()?;
    let model = Model::from_name(&name).ok_or_else(|| format!("unknown camera model {name:?}"))?;
    let fov = r.f64()?;
    let (width, height) = (r.usize()?, r.usize()?);
    let (yaw, pitch, roll) = (r.f64()?, r.f64()?, r.f64()?);
    Ok(Camera { model, fov, width, height, yaw, pitch, roll })
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let camera = read_camera(&mut r)?;
    r.finish()?;
    Ok(Value::new(camera))
}

/// The JSON object of a camera (keys `model`, `fov`, `width`, `height`, `yaw`, `pitch`, `roll`,
/// `world_to_camera`).
pub fn to_json_value(c: &Camera) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("model".into(), c.model.name().into());
    map.insert("fov".into(), num(c.fov));
    map.insert("width".into(), c.width.into());
    map.insert("height".into(), c.height.into());
    map.insert("yaw".into(), num(c.yaw));
    map.insert("pitch".into(), num(c.pitch));
    map.insert("roll".into(), num(c.roll));
    let rows = c.world_to_camera().map(|row| serde_json::Value::Array(row.iter().map(|&v| num(v)).collect()));
    map.insert("world_to_camera".into(), serde_json::Value::Array(rows.to_vec()));
    serde_json::Value::Object(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(m: [[f64; 3]; 3], d: DVec3) -> DVec3 {
        let [r0, r1, r2] = m.map(DVec3::from_array);
        DVec3::new(r0.dot(d), r1.dot(d), r2.dot(d))
    }

    #[test]
    fn world_to_camera_undoes_the_view_rotation() {
        let cams = [(0.0, 0.0, 0.0), (90.0, 0.0, 0.0), (30.0, 10.0, 0.0), (-123.0, 45.0, 17.0), (200.0, -80.0, -60.0)];
        for (yaw, pitch, roll) in cams {
            let cam = Camera { model: Model::Perspective, fov: 60.0, width: 8, height: 6, yaw, pitch, roll };
            let m = cam.world_to_camera();
            // The centre ray, and the camera's right and up, come back to the camera axes.
            assert!((apply(m, cam.forward()) - DVec3::NEG_Z).length() < 1e-12, "{yaw} {pitch} {roll}");
            let r = cam.rotation();
            assert!((apply(m, r.apply(DVec3::X)) - DVec3::X).length() < 1e-12);
            assert!((apply(m, r.apply(DVec3::Y)) - DVec3::Y).length() < 1e-12);
        }
        // Yaw 90 looks left (-X): the world's -X is straight ahead of that camera.
        let left =
            Camera { model: Model::Perspective, fov: 60.0, width: 8, height: 6, yaw: 90.0, pitch: 0.0, roll: 0.0 };
        assert!((left.forward() - DVec3::NEG_X).length() < 1e-12);
        assert!((apply(left.world_to_camera(), DVec3::NEG_X) - DVec3::NEG_Z).length() < 1e-12);
    }

    #[test]
    fn round_trips_and_saves_json() {
        let c =
            Camera { model: Model::Fisheye, fov: 187.5, width: 640, height: 480, yaw: -30.0, pitch: 12.5, roll: 3.0 };
        let mut bytes = Vec::new();
        c.encode(&mut bytes);
        assert_eq!(decode(&bytes).unwrap().get::<Camera>(), Some(&c));
        for cut in [0, 5, bytes.len() - 1] {
            let e = decode(&bytes[..cut]).unwrap_err();
            assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
        }
        let mut bad = Vec::new();
        Writer(&mut bad).str("Pinhole");
        assert!(decode(&bad).unwrap_err().contains("unknown camera model"));

        let json: serde_json::Value = serde_json::from_str(&to_json_value(&c).to_string()).unwrap();
        let keys: Vec<&String> = json.as_object().unwrap().keys().collect();
        assert_eq!(keys, ["model", "fov", "width", "height", "yaw", "pitch", "roll", "world_to_camera"]);
        assert_eq!(json["model"], "Fisheye");
        assert_eq!(json["width"], 640);
        assert_eq!(json["pitch"].as_f64(), Some(12.5));
        let m = c.world_to_camera();
        for (i, row) in json["world_to_camera"].as_array().unwrap().iter().enumerate() {
            // serde_json's float parser may miss the last bit: compare to 1e-15.
            let row: Vec<f64> = row.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
            assert!(row.iter().zip(m[i]).all(|(a, b)| (a - b).abs() < 1e-15), "{row:?} {:?}", m[i]);
        }
    }
}
