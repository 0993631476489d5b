//! The `image` and `scalar field` types of an [`Image`], and its cache payload: width, height,
//! channel names, then the f32 samples.

use super::Image;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

pub static IMAGE: TypeSpec = TypeSpec {
    name: "image",
    doc: "a float raster of 2 or more named channels (RGB, RGBA, ...), linear radiance",
    decode,
};

pub static SCALAR_FIELD: TypeSpec = TypeSpec {
    name: "scalar field",
    doc: "a one-channel float raster (luminance, weights, masks, one channel of an image)",
    decode,
};

impl ValueData for Image {
    fn value_type(&self) -> ValueType {
        if self.channels == 1 {
            ValueType(&SCALAR_FIELD)
        } else {
            ValueType(&IMAGE)
        }
    }
    fn approx_bytes(&self) -> usize {
        self.data.len() * 4
    }
    fn summary(&self) -> String {
        let n = self.pixel_count().max(1) as f64;
        let means: Vec<String> = (0..self.channels)
            .map(|c| {
                let sum: f64 = self.data.iter().skip(c).step_by(self.channels).map(|&v| v as f64).sum();
                format!("{} {:.6}", self.names[c], sum / n)
            })
            .collect();
        format!("{}x{} image, channel means: {}", self.width, self.height, means.join(", "))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.width as u64);
        w.u64(self.height as u64);
        w.u64(self.names.len() as u64);
        for n in &self.names {
            w.str(n);
        }
        w.f32s(&self.data);
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = r.usize()?;
    let height = r.usize()?;
    let channels = r.usize()?;
    r.need(channels.saturating_mul(8))?;
    let names = (0..channels).map(|_| r.str()).collect::<Result<Vec<_>, _>>()?;
    let data = r.f32s()?;
    r.finish()?;
    if channels == 0 || width.checked_mul(height).and_then(|p| p.checked_mul(channels)) != Some(data.len()) {
        return Err("image dimensions do not match its data".into());
    }
    Ok(Value::new(Image::with_names(width, height, names, data)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_names_and_truncation_is_an_error() {
        let img = Image::with_names(
            2,
            1,
            vec!["R".into(), "G".into(), "B".into(), "A".into()],
            (0..8).map(|v| v as f32).collect(),
        );
        let mut bytes = Vec::new();
        img.encode(&mut bytes);
        let back = decode(&bytes).unwrap();
        assert_eq!(back.value_type(), ValueType(&IMAGE));
        assert_eq!(back.get::<Image>().unwrap(), &img);
        for cut in [0, 8, bytes.len() - 1] {
            let e = decode(&bytes[..cut]).unwrap_err();
            assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
        }
        let y = Value::new(Image::new(2, 2, 1));
        assert_eq!(y.value_type(), ValueType(&SCALAR_FIELD));
    }
}
