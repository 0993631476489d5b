//! Values to bytes and back, for the disk cache.
//!
//! Little-endian, a tag byte per value, lengths as u64. Decoding checks every length against
//! the bytes that remain before allocating, so a corrupt entry is an error, never a huge
//! allocation or a panic. Integrity as a whole is checked by the store's BLAKE3 checksum.

use std::sync::Arc;

use crate::data::{Curves, Distribution2D, Image, Metrics, Sample, SampleSet};
use crate::engine::value::{FileBlob, Value};

/// Bump when the byte layout of any value changes.
pub const CODEC_VERSION: u32 = 1;

const TAG_IMAGE: u8 = 1;
const TAG_DISTRIBUTION: u8 = 2;
const TAG_SAMPLES: u8 = 3;
const TAG_CURVES: u8 = 4;
const TAG_METRICS: u8 = 5;
const TAG_FILE: u8 = 6;

pub fn encode(value: &Value) -> Vec<u8> {
    let mut w = Writer(Vec::with_capacity(value.approx_bytes() + 64));
    match value {
        Value::Image(img) => {
            w.u8(TAG_IMAGE);
            w.u64(img.width as u64);
            w.u64(img.height as u64);
            w.u64(img.channels as u64);
            w.f32s(&img.data);
        }
        Value::Distribution(d) => {
            w.u8(TAG_DISTRIBUTION);
            w.u64(d.width as u64);
            w.u64(d.height as u64);
            w.u8(u8::from(d.sin_theta));
            w.u8(u8::from(d.carries_light));
            w.f64(d.total);
            w.f64(d.luminance_integral);
            w.f64s(&d.func);
            w.f64s(&d.conditional_cdf);
            w.f64s(&d.row_sums);
            w.f64s(&d.marginal_cdf);
        }
        Value::Samples(s) => {
            w.u8(TAG_SAMPLES);
            w.u64(s.width as u64);
            w.u64(s.height as u64);
            w.u64(s.samples.len() as u64);
            for p in &s.samples {
                w.u64(p.x as u64);
                w.u64(p.y as u64);
                w.f32s_raw(&[p.theta, p.phi, p.dir[0], p.dir[1], p.dir[2], p.pdf]);
            }
        }
        Value::Curves(c) => {
            w.u8(TAG_CURVES);
            w.str(&c.title);
            w.str(&c.x_name);
            w.str(&c.x_label);
            w.str(&c.y_label);
            w.f64s(&c.x);
            w.u64(c.series.len() as u64);
            for (name, ys) in &c.series {
                w.str(name);
                w.f64s(ys);
            }
            w.u64(c.scalars.len() as u64);
            for (name, v) in &c.scalars {
                w.str(name);
                match v {
                    Some(v) => {
                        w.u8(1);
                        w.f64(*v);
                    }
                    None => w.u8(0),
                }
            }
            w.u64(c.markers.len() as u64);
            for (label, x) in &c.markers {
                w.str(label);
                w.f64(*x);
            }
        }
        Value::Metrics(m) => {
            w.u8(TAG_METRICS);
            w.u64(m.fields.len() as u64);
            for (name, v) in &m.fields {
                w.str(name);
                w.f64(*v);
            }
        }
        Value::File(f) => {
            w.u8(TAG_FILE);
            w.str(&f.rel_path);
            w.bytes(&f.bytes);
        }
    }
    w.0
}

pub fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader { buf: bytes, pos: 0 };
    let value = match r.u8()? {
        TAG_IMAGE => {
            let width = r.usize()?;
            let height = r.usize()?;
            let channels = r.usize()?;
            let data = r.f32s()?;
            if !(channels == 1 || channels == 3)
                || width.checked_mul(height).and_then(|p| p.checked_mul(channels)) != Some(data.len())
            {
                return Err("image dimensions do not match its data".into());
            }
            Value::Image(Arc::new(Image { width, height, channels, data }))
        }
        TAG_DISTRIBUTION => {
            let width = r.usize()?;
            let height = r.usize()?;
            let sin_theta = r.u8()? != 0;
            let carries_light = r.u8()? != 0;
            let total = r.f64()?;
            let luminance_integral = r.f64()?;
            let func = r.f64s()?;
            let conditional_cdf = r.f64s()?;
            let row_sums = r.f64s()?;
            let marginal_cdf = r.f64s()?;
            let n = width.checked_mul(height).ok_or("distribution size overflows")?;
            if func.len() != n
                || conditional_cdf.len() != height * (width + 1)
                || row_sums.len() != height
                || marginal_cdf.len() != height + 1
            {
                return Err("distribution arrays do not match its size".into());
            }
            Value::Distribution(Arc::new(Distribution2D {
                width,
                height,
                sin_theta,
                func,
                conditional_cdf,
                row_sums,
                marginal_cdf,
                total,
                luminance_integral,
                carries_light,
            }))
        }
        TAG_SAMPLES => {
            let width = r.u64()? as u32;
            let height = r.u64()? as u32;
            let count = r.usize()?;
            r.need(count.saturating_mul(16 + 24))?;
            let mut samples = Vec::with_capacity(count);
            for _ in 0..count {
                let x = r.u64()? as u32;
                let y = r.u64()? as u32;
                let v = r.f32_array::<6>()?;
                samples.push(Sample { x, y, theta: v[0], phi: v[1], dir: [v[2], v[3], v[4]], pdf: v[5] });
            }
            Value::Samples(Arc::new(SampleSet { width, height, samples }))
        }
        TAG_CURVES => {
            let title = r.str()?;
            let x_name = r.str()?;
            let x_label = r.str()?;
            let y_label = r.str()?;
            let x = r.f64s()?;
            let n = r.usize()?;
            r.need(n.saturating_mul(16))?;
            let mut series = Vec::with_capacity(n);
            for _ in 0..n {
                series.push((r.str()?, r.f64s()?));
            }
            let n = r.usize()?;
            r.need(n.saturating_mul(9))?;
            let mut scalars = Vec::with_capacity(n);
            for _ in 0..n {
                let name = r.str()?;
                let v = if r.u8()? == 1 { Some(r.f64()?) } else { None };
                scalars.push((name, v));
            }
            let n = r.usize()?;
            r.need(n.saturating_mul(16))?;
            let mut markers = Vec::with_capacity(n);
            for _ in 0..n {
                markers.push((r.str()?, r.f64()?));
            }
            Value::Curves(Arc::new(Curves { title, x_name, x_label, y_label, x, series, scalars, markers }))
        }
        TAG_METRICS => {
            let n = r.usize()?;
            r.need(n.saturating_mul(16))?;
            let mut fields = Vec::with_capacity(n);
            for _ in 0..n {
                fields.push((r.str()?, r.f64()?));
            }
            Value::Metrics(Arc::new(Metrics { fields }))
        }
        TAG_FILE => {
            let rel_path = r.str()?;
            let bytes = r.bytes()?.to_vec();
            Value::File(Arc::new(FileBlob { rel_path, bytes }))
        }
        t => return Err(format!("unknown value tag {t}")),
    };
    if r.pos != bytes.len() {
        return Err(format!("{} trailing bytes", bytes.len() - r.pos));
    }
    Ok(value)
}

struct Writer(Vec<u8>);

impl Writer {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }
    fn str(&mut self, s: &str) {
        self.bytes(s.as_bytes());
    }
    fn f32s_raw(&mut self, v: &[f32]) {
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
    fn f32s(&mut self, v: &[f32]) {
        self.u64(v.len() as u64);
        self.f32s_raw(v);
    }
    fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
}

struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn need(&self, n: usize) -> Result<(), String> {
        if self.buf.len() - self.pos < n {
            Err(format!("truncated: need {n} bytes at offset {}, {} left", self.pos, self.buf.len() - self.pos))
        } else {
            Ok(())
        }
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        self.need(n)?;
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    fn usize(&mut self) -> Result<usize, String> {
        usize::try_from(self.u64()?).map_err(|_| "length does not fit in memory".to_string())
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.usize()?;
        self.take(n)
    }
    fn str(&mut self) -> Result<String, String> {
        String::from_utf8(self.bytes()?.to_vec()).map_err(|_| "invalid UTF-8 in a string".to_string())
    }
    fn f32_array<const N: usize>(&mut self) -> Result<[f32; N], String> {
        let raw = self.take(4 * N)?;
        let mut out = [0.0f32; N];
        for (o, c) in out.iter_mut().zip(raw.chunks_exact(4)) {
            *o = f32::from_le_bytes(c.try_into().expect("4 bytes"));
        }
        Ok(out)
    }
    fn f32s(&mut self) -> Result<Vec<f32>, String> {
        let n = self.usize()?;
        let raw = self.take(n.checked_mul(4).ok_or("length overflows")?)?;
        Ok(raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect())
    }
    fn f64s(&mut self) -> Result<Vec<f64>, String> {
        let n = self.usize()?;
        let raw = self.take(n.checked_mul(8).ok_or("length overflows")?)?;
        Ok(raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_round_trip_and_truncation_is_an_error() {
        let img = Image::from_vec(3, 2, 3, (0..18).map(|i| i as f32 * 0.5).collect());
        let bytes = encode(&Value::image(img.clone()));
        match decode(&bytes).unwrap() {
            Value::Image(back) => assert_eq!(*back, img),
            other => panic!("{other:?}"),
        }
        for cut in [0, 1, 9, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn huge_claimed_length_is_refused_without_allocating() {
        let mut bytes = vec![TAG_IMAGE];
        for v in [1u64 << 40, 1 << 40, 3, u64::MAX / 2] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        assert!(decode(&bytes).is_err());
    }

    #[test]
    fn curves_round_trip() {
        let c = Curves {
            title: "t".into(),
            x_name: "x".into(),
            x_label: "xl".into(),
            y_label: "yl".into(),
            x: vec![0.0, 1.0],
            series: vec![("a".into(), vec![1.0, 2.0])],
            scalars: vec![("s".into(), Some(1.5)), ("n".into(), None)],
            markers: vec![("m".into(), 0.5)],
        };
        match decode(&encode(&Value::Curves(Arc::new(c.clone())))).unwrap() {
            Value::Curves(back) => assert_eq!(*back, c),
            other => panic!("{other:?}"),
        }
    }
}
