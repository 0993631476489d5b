//! `Brackets` (`brackets` in graphs): the frames of one bracketed exposure sequence as the camera
//! wrote them (integer codes, 8 or 16 bits per channel, RGB), each with its exposure time, sorted
//! from the shortest exposure to the longest. What `LoadBrackets` makes and `AlignBrackets`,
//! `CalibrateResponse`, `MergeBrackets` and `FuseExposures` read.
//!
//! The codes stay integers (`u8` or `u16`), not floats: seven 24-megapixel frames are 504 MB as
//! bytes and 2 GB as f32, and a merge must fit beside them (issue 38: the peak at most the decoded
//! frames plus the f32 output). An aligned frame keeps its size; the pixels its shift uncovered
//! are filled from the edge and marked 0 in its `covered` mask, which a merge gives no weight.

use crate::bytes::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// One frame's codes, row-major RGB interleaved (`width * height * 3`), row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub enum Codes {
    U8(Vec<u8>),
    U16(Vec<u16>),
}

impl Codes {
    pub fn len(&self) -> usize {
        match self {
            Codes::U8(v) => v.len(),
            Codes::U16(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The code at sample index `i` (pixel * 3 + channel).
    #[inline]
    pub fn get(&self, i: usize) -> u16 {
        match self {
            Codes::U8(v) => v[i] as u16,
            Codes::U16(v) => v[i],
        }
    }

    /// The bits per channel of this storage.
    pub fn bits(&self) -> u8 {
        match self {
            Codes::U8(_) => 8,
            Codes::U16(_) => 16,
        }
    }
}

/// One exposure of a bracket.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The file's name (for messages and reports), e.g. `IMG_0042.JPG`.
    pub name: String,
    /// The exposure time in seconds (> 0).
    pub time: f64,
    pub codes: Codes,
    /// After alignment, 1 where the pixel is the frame's own and 0 where the shift uncovered it
    /// and it was filled from the edge (`width * height`); `None`: every pixel is covered.
    pub covered: Option<Vec<u8>>,
}

/// A bracketed exposure sequence: frames of one size and bit depth, sorted by exposure time,
/// shortest first. The fields are public plain data; [`Brackets::new`] checks the invariants
/// (operators that build one from user files report a violation as a pipeline error first).
#[derive(Clone, Debug, PartialEq)]
pub struct Brackets {
    pub width: usize,
    pub height: usize,
    /// 8 or 16: codes run 0..=2^bits - 1.
    pub bit_depth: u8,
    pub frames: Vec<Frame>,
}

impl Brackets {
    /// Checks every frame's length, bit depth, time and mask, then sorts the frames by time
    /// (a stable sort: equal times keep their order, which `LoadBrackets` refuses beforehand).
    pub fn new(width: usize, height: usize, bit_depth: u8, mut frames: Vec<Frame>) -> Result<Self, String> {
        if bit_depth != 8 && bit_depth != 16 {
            return Err(format!("a bracket has 8 or 16 bits per channel, not {bit_depth}"));
        }
        let samples = width.checked_mul(height).and_then(|p| p.checked_mul(3)).ok_or("bracket size overflows")?;
        for f in &frames {
            if f.codes.len() != samples {
                return Err(format!("frame {} has {} samples, not {width} x {height} x 3", f.name, f.codes.len()));
            }
            if f.codes.bits() != bit_depth {
                return Err(format!("frame {} has {} bits per channel, not {bit_depth}", f.name, f.codes.bits()));
            }
            if !(f.time.is_finite() && f.time > 0.0) {
                return Err(format!("frame {} has exposure time {}, not a positive number of seconds", f.name, f.time));
            }
            if f.covered.as_ref().is_some_and(|m| m.len() != width * height) {
                return Err(format!("frame {}'s coverage mask is not {width} x {height}", f.name));
            }
        }
        frames.sort_by(|a, b| a.time.total_cmp(&b.time));
        Ok(Brackets { width, height, bit_depth, frames })
    }

    /// The largest code: 255 or 65535.
    pub fn max_code(&self) -> u16 {
        if self.bit_depth == 8 {
            u8::MAX as u16
        } else {
            u16::MAX
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }
}

pub static BRACKETS: TypeSpec = TypeSpec {
    name: "brackets",
    doc: "bracketed exposures: frames of integer codes (8 or 16 bits, RGB) with their exposure times, shortest first",
    decode,
};

impl ValueData for Brackets {
    fn value_type(&self) -> ValueType {
        ValueType(&BRACKETS)
    }
    fn approx_bytes(&self) -> usize {
        self.frames
            .iter()
            .map(|f| f.codes.len() * (f.codes.bits() as usize / 8) + f.covered.as_ref().map_or(0, Vec::len))
            .sum()
    }
    fn summary(&self) -> String {
        let times: Vec<String> = self.frames.iter().map(|f| format_time(f.time)).collect();
        format!(
            "{} frames of {}x{} at {} bits, exposures {}",
            self.frames.len(),
            self.width,
            self.height,
            self.bit_depth,
            times.join(", ")
        )
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.width as u64);
        w.u64(self.height as u64);
        w.u8(self.bit_depth);
        w.u64(self.frames.len() as u64);
        for f in &self.frames {
            w.str(&f.name);
            w.f64(f.time);
            match &f.codes {
                Codes::U8(v) => w.bytes(v),
                Codes::U16(v) => {
                    let bytes: Vec<u8> = v.iter().flat_map(|c| c.to_le_bytes()).collect();
                    w.bytes(&bytes)
                }
            }
            match &f.covered {
                None => w.u8(0),
                Some(m) => {
                    w.u8(1);
                    w.bytes(m);
                }
            }
        }
    }
}

/// An exposure time as photographers write it: `1/250 s` below a second, `2 s` above.
pub fn format_time(t: f64) -> String {
    if t < 1.0 && t > 0.0 {
        let inv = 1.0 / t;
        if (inv - inv.round()).abs() < 1e-3 * inv {
            return format!("1/{} s", inv.round());
        }
    }
    format!("{t} s")
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = r.usize()?;
    let height = r.usize()?;
    let bit_depth = r.u8()?;
    let n = r.usize()?;
    r.need(n.saturating_mul(26))?;
    let mut frames = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.str()?;
        let time = r.f64()?;
        let raw = r.bytes()?;
        let codes = match bit_depth {
            8 => Codes::U8(raw.to_vec()),
            16 if raw.len() % 2 == 0 => {
                Codes::U16(raw.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect())
            }
            _ => return Err(format!("bracket frame of {} bytes at {bit_depth} bits", raw.len())),
        };
        let covered = match r.u8()? {
            0 => None,
            1 => Some(r.bytes()?.to_vec()),
            t => return Err(format!("bad coverage tag {t}")),
        };
        frames.push(Frame { name, time, codes, covered });
    }
    r.finish()?;
    Ok(Value::new(Brackets::new(width, height, bit_depth, frames)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(name: &str, time: f64, codes: Codes) -> Frame {
        Frame { name: name.into(), time, codes, covered: None }
    }

    #[test]
    fn frames_are_sorted_by_time_and_the_codec_round_trips() {
        let b = Brackets::new(
            2,
            1,
            16,
            vec![
                frame("b.tif", 0.5, Codes::U16(vec![1, 2, 3, 65535, 5, 6])),
                Frame { covered: Some(vec![1, 0]), ..frame("a.tif", 1.0 / 250.0, Codes::U16(vec![9; 6])) },
            ],
        )
        .unwrap();
        assert_eq!(b.frames[0].name, "a.tif");
        assert_eq!(b.max_code(), 65535);
        assert_eq!(b.summary(), "2 frames of 2x1 at 16 bits, exposures 1/250 s, 1/2 s");
        let mut bytes = Vec::new();
        b.encode(&mut bytes);
        let back = decode(&bytes).unwrap();
        assert_eq!(back.get::<Brackets>().unwrap(), &b);
        for cut in [0, 20, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn broken_invariants_are_errors_naming_the_frame() {
        let e = Brackets::new(2, 2, 8, vec![frame("x.jpg", 1.0, Codes::U8(vec![0; 5]))]).unwrap_err();
        assert!(e.contains("frame x.jpg has 5 samples, not 2 x 2 x 3"), "{e}");
        let e = Brackets::new(1, 1, 8, vec![frame("y.png", 1.0, Codes::U16(vec![0; 3]))]).unwrap_err();
        assert!(e.contains("frame y.png has 16 bits per channel, not 8"), "{e}");
        let e = Brackets::new(1, 1, 8, vec![frame("z.png", f64::NAN, Codes::U8(vec![0; 3]))]).unwrap_err();
        assert!(e.contains("exposure time NaN"), "{e}");
        assert!(Brackets::new(1, 1, 12, vec![]).is_err());
    }
}
