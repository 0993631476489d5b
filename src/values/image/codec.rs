//! The `image` and `scalar field` types of an [`Image`], and its cache payload: width, height,
//! channel names, then the f32 samples as runs: records of (a count of `+0.0` samples, a count of
//! samples stored as they are, those samples). A run of zeros is recorded only from
//! [`MIN_ZERO_RUN`] samples (or at the end), so an image without long zero runs costs 16 bytes
//! more than its samples. Renders on a transparent film are mostly zeros: a protocol sphere
//! (`ProbeSphere`, 960 x 540 RGBA and its mask) is 10.4 MB of samples and 1.4 MB of payload,
//! which is what a batch over a test set writes to the cache per sphere.

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
        encode_runs(&mut w, &self.data);
    }
}

/// Zero runs shorter than this stay inside the stored samples.
pub const MIN_ZERO_RUN: usize = 64;

/// The number of `+0.0` samples (bit pattern 0; `-0.0` is stored as it is) from the start.
fn zeros_at(data: &[f32]) -> usize {
    data.iter().take_while(|x| x.to_bits() == 0).count()
}

/// `data` as its count, then (zeros, stored count, stored samples) records.
fn encode_runs(w: &mut Writer, data: &[f32]) {
    let n = data.len();
    w.u64(n as u64);
    let mut i = 0;
    while i < n {
        let z = zeros_at(&data[i..]);
        let zeros = if z >= MIN_ZERO_RUN || i + z == n { z } else { 0 };
        let start = i + zeros;
        let mut end = start;
        while end < n {
            if data[end].to_bits() != 0 {
                end += 1;
                continue;
            }
            let z = zeros_at(&data[end..]);
            if z >= MIN_ZERO_RUN || end + z == n {
                break;
            }
            end += z;
        }
        w.u64(zeros as u64);
        w.u64((end - start) as u64);
        w.f32s_raw(&data[start..end]);
        i = end;
    }
}

/// The samples [`encode_runs`] wrote, `expected` of them: an error, never a panic or an
/// allocation beyond `expected`, when the records do not add up to it.
fn decode_runs(r: &mut Reader, expected: usize) -> Result<Vec<f32>, String> {
    let n = r.usize()?;
    if n != expected {
        return Err(format!("image data holds {n} samples where its size needs {expected}"));
    }
    let mut data = Vec::new();
    data.try_reserve_exact(n).map_err(|_| format!("cannot allocate {n} samples"))?;
    while data.len() < n {
        let zeros = r.usize()?;
        let stored = r.usize()?;
        let left = n - data.len();
        if zeros > left || stored > left - zeros || zeros + stored == 0 {
            return Err("image data runs do not add up to its size".into());
        }
        data.resize(data.len() + zeros, 0.0);
        let bytes = r.take(stored * 4)?;
        data.extend(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
    }
    Ok(data)
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = r.usize()?;
    let height = r.usize()?;
    let channels = r.usize()?;
    r.need(channels.saturating_mul(8))?;
    let names = (0..channels).map(|_| r.str()).collect::<Result<Vec<_>, _>>()?;
    let Some(samples) = width.checked_mul(height).and_then(|p| p.checked_mul(channels)).filter(|_| channels > 0) else {
        return Err("image dimensions do not match its data".into());
    };
    let data = decode_runs(&mut r, samples)?;
    r.finish()?;
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

    fn round_trip(data: Vec<f32>) -> (Vec<f32>, usize) {
        let img = Image::from_vec(data.len(), 1, 1, data);
        let mut bytes = Vec::new();
        img.encode(&mut bytes);
        let back = decode(&bytes).unwrap();
        (back.get::<Image>().unwrap().data.clone(), bytes.len())
    }

    #[test]
    fn zero_runs_shrink_the_payload_and_keep_every_bit() {
        // A transparent film around a disc: long zero runs, short ones inside, -0.0 and NaN kept.
        let mut data = vec![0.0f32; 10_000];
        data[3000..3100].iter_mut().enumerate().for_each(|(i, v)| *v = i as f32 * 0.5 - 7.0);
        data[3100..3110].fill(0.0);
        data[3110] = -0.0;
        data[3111] = f32::NAN;
        data[9999] = 1.0;
        let (back, len) = round_trip(data.clone());
        assert!(back.iter().zip(&data).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(len < 1000, "{len} bytes");
        // No long zero run: the samples as they are, one record.
        let dense: Vec<f32> = (0..1000).map(|i| (i % 7) as f32).collect();
        let (back, len) = round_trip(dense.clone());
        assert_eq!(back, dense);
        assert!(len <= 1000 * 4 + 100, "{len} bytes");
        for data in [vec![], vec![0.0; 5], vec![0.0; 500], vec![1.0; 3]] {
            assert_eq!(round_trip(data.clone()).0, data);
        }
    }

    #[test]
    fn runs_that_do_not_add_up_are_errors() {
        let img = Image::from_vec(4, 1, 1, vec![0.0; 4]);
        let mut bytes = Vec::new();
        img.encode(&mut bytes);
        // The last record's zero count (4) is at 16 bytes from the end; claim more.
        let at = bytes.len() - 16;
        bytes[at] = 200;
        assert!(decode(&bytes).unwrap_err().contains("do not add up"));
        bytes[at] = 0;
        assert!(decode(&bytes).unwrap_err().contains("do not add up"));
    }
}
