//! `Exif` (`exif` in graphs): what a photograph's EXIF block says about how it was taken, as
//! `LoadImage` reads it: exposure time in seconds, f-number, ISO speed, camera make and model,
//! each `None` where the file does not say (a PNG from an editor has none of them). Displayed
//! after a run and saved (`.json`) as one object:
//!
//! ```text
//! {"exposure_time": 0.004, "f_number": 8, "iso": 100, "make": "Canon", "model": "EOS R5"}
//! ```
//!
//! with `null` for a missing field. Reading the block is the file formats' job
//! (`crate::formats::photo`); this module holds the data and its codec only.

use crate::bytes::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// The camera settings of one photograph, where its EXIF gives them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Exif {
    /// ExposureTime (tag 0x829A), seconds.
    pub exposure_time: Option<f64>,
    /// FNumber (tag 0x829D).
    pub f_number: Option<f64>,
    /// PhotographicSensitivity (ISOSpeedRatings, tag 0x8827).
    pub iso: Option<f64>,
    /// Make (tag 0x010F), trimmed.
    pub make: Option<String>,
    /// Model (tag 0x0110), trimmed.
    pub model: Option<String>,
}

pub static EXIF: TypeSpec = TypeSpec {
    name: "exif",
    doc: "a photograph's EXIF settings: exposure time (s), f-number, ISO, make and model, each where the file gives it",
    decode,
};

impl ValueData for Exif {
    fn value_type(&self) -> ValueType {
        ValueType(&EXIF)
    }
    fn approx_bytes(&self) -> usize {
        std::mem::size_of::<Exif>()
            + self.make.as_ref().map_or(0, String::len)
            + self.model.as_ref().map_or(0, String::len)
    }
    fn summary(&self) -> String {
        let mut parts = Vec::new();
        if let Some(t) = self.exposure_time {
            parts.push(super::brackets::format_time(t));
        }
        if let Some(f) = self.f_number {
            parts.push(format!("f/{f}"));
        }
        if let Some(iso) = self.iso {
            parts.push(format!("ISO {iso}"));
        }
        let camera: Vec<&str> = [&self.make, &self.model].into_iter().flatten().map(String::as_str).collect();
        if !camera.is_empty() {
            parts.push(camera.join(" "));
        }
        if parts.is_empty() {
            "EXIF: none of exposure time, f-number, ISO, make, model".into()
        } else {
            format!("EXIF: {}", parts.join(", "))
        }
    }
    fn display(&self) -> Option<String> {
        Some(to_json(self).trim_end().to_string())
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        for v in [self.exposure_time, self.f_number, self.iso] {
            match v {
                None => w.u8(0),
                Some(v) => {
                    w.u8(1);
                    w.f64(v);
                }
            }
        }
        for s in [&self.make, &self.model] {
            match s {
                None => w.u8(0),
                Some(s) => {
                    w.u8(1);
                    w.str(s);
                }
            }
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let exposure_time = number(&mut r)?;
    let f_number = number(&mut r)?;
    let iso = number(&mut r)?;
    let make = text(&mut r)?;
    let model = text(&mut r)?;
    r.finish()?;
    Ok(Value::new(Exif { exposure_time, f_number, iso, make, model }))
}

fn number(r: &mut Reader) -> Result<Option<f64>, String> {
    match r.u8()? {
        0 => Ok(None),
        1 => r.f64().map(Some),
        f => Err(format!("bad exif flag {f}")),
    }
}

fn text(r: &mut Reader) -> Result<Option<String>, String> {
    match r.u8()? {
        0 => Ok(None),
        1 => r.str().map(Some),
        f => Err(format!("bad exif flag {f}")),
    }
}

/// The JSON object: keys `exposure_time`, `f_number`, `iso`, `make`, `model`, `null` where absent.
pub fn to_json_value(e: &Exif) -> serde_json::Value {
    let num = |v: Option<f64>| v.map_or(serde_json::Value::Null, super::json::num);
    let text = |s: &Option<String>| s.clone().map_or(serde_json::Value::Null, serde_json::Value::String);
    let mut map = serde_json::Map::new();
    map.insert("exposure_time".into(), num(e.exposure_time));
    map.insert("f_number".into(), num(e.f_number));
    map.insert("iso".into(), num(e.iso));
    map.insert("make".into(), text(&e.make));
    map.insert("model".into(), text(&e.model));
    serde_json::Value::Object(map)
}

/// The JSON text of the settings.
pub fn to_json(e: &Exif) -> String {
    super::json::text(&to_json_value(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_codec_round_trips_and_absent_fields_are_null() {
        let full = Exif {
            exposure_time: Some(1.0 / 250.0),
            f_number: Some(8.0),
            iso: Some(100.0),
            make: Some("Canon".into()),
            model: Some("EOS R5".into()),
        };
        for e in [full.clone(), Exif::default(), Exif { model: Some("X".into()), ..Exif::default() }] {
            let mut bytes = Vec::new();
            e.encode(&mut bytes);
            assert_eq!(decode(&bytes).unwrap().get::<Exif>().unwrap(), &e);
            assert!(decode(&bytes[..bytes.len() - 1]).is_err());
        }
        assert_eq!(full.summary(), "EXIF: 1/250 s, f/8, ISO 100, Canon EOS R5");
        let json: serde_json::Value = serde_json::from_str(&full.display().unwrap()).unwrap();
        assert_eq!(json["exposure_time"], 0.004);
        assert_eq!(json["model"], "EOS R5");
        let none: serde_json::Value = serde_json::from_str(&Exif::default().display().unwrap()).unwrap();
        assert!(none["iso"].is_null() && none["make"].is_null(), "{none}");
    }
}
