//! `SampleSet` (`sample set` in graphs): directions drawn on the sphere, each with its
//! solid-angle pdf. Saved as `.csv` (`index,x,y,theta,phi,dx,dy,dz,pdf`) or `.json`
//! (`crate::formats::save::samples`).
//!
//! Direction convention (see `geometry::latlong`): +Y up; a lat-long texel (x, y) of a W x H map has
//! theta = pi*(y+0.5)/H (polar angle from +Y) and phi = 2*pi*(x+0.5)/W.

use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// One sampled direction.
/// Plain data, its fields public: the samplers write them, the shading operators read them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Texel column and row on the reference lat-long grid (`SampleSet::width` x `height`).
    pub x: u32,
    pub y: u32,
    /// Polar angle from +Y and azimuth, radians.
    pub theta: f32,
    pub phi: f32,
    /// Unit direction.
    pub dir: [f32; 3],
    /// Probability density with respect to solid angle (sr^-1). Finite and >= 0.
    pub pdf: f32,
}

impl Sample {
    /// A sample from f64 maths: texel (x, y), angles, unit direction and solid-angle pdf, stored
    /// in f32 (the precision every consumer reads them at).
    pub fn new(x: usize, y: usize, theta: f64, phi: f64, dir: [f64; 3], pdf: f64) -> Sample {
        Sample {
            x: x as u32,
            y: y as u32,
            theta: theta as f32,
            phi: phi as f32,
            dir: dir.map(|c| c as f32),
            pdf: pdf as f32,
        }
    }
}

/// An ordered set of samples with the lat-long grid their texel indices refer to.
/// Plain data, its fields public, like [`Sample`]'s.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleSet {
    pub width: u32,
    pub height: u32,
    pub samples: Vec<Sample>,
    /// The integral over the sphere of the luminance these samples were drawn in proportion to
    /// (`Distribution2D::luminance_integral` of their distribution); `None` for samples not
    /// drawn from a map (a Phong lobe). The seed's estimator scales by it.
    pub luminance_integral: Option<f64>,
}

pub static SAMPLES: TypeSpec =
    TypeSpec { name: "sample set", doc: "directions with their solid-angle pdfs, on a lat-long grid", decode };

impl ValueData for SampleSet {
    fn value_type(&self) -> ValueType {
        ValueType(&SAMPLES)
    }
    fn approx_bytes(&self) -> usize {
        self.samples.len() * std::mem::size_of::<Sample>()
    }
    fn summary(&self) -> String {
        format!("{} samples on a {}x{} lat-long grid", self.samples.len(), self.width, self.height)
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.width as u64);
        w.u64(self.height as u64);
        match self.luminance_integral {
            Some(v) => {
                w.u8(1);
                w.f64(v);
            }
            None => w.u8(0),
        }
        w.u64(self.samples.len() as u64);
        for p in &self.samples {
            w.u64(p.x as u64);
            w.u64(p.y as u64);
            w.f32s_raw(&[p.theta, p.phi, p.dir[0], p.dir[1], p.dir[2], p.pdf]);
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = u32::try_from(r.u64()?).map_err(|_| "width overflows")?;
    let height = u32::try_from(r.u64()?).map_err(|_| "height overflows")?;
    let luminance_integral = if r.u8()? == 1 { Some(r.f64()?) } else { None };
    let count = r.usize()?;
    r.need(count.saturating_mul(16 + 24))?;
    let mut samples = Vec::with_capacity(count);
    for _ in 0..count {
        let x = u32::try_from(r.u64()?).map_err(|_| "texel index overflows")?;
        let y = u32::try_from(r.u64()?).map_err(|_| "texel index overflows")?;
        let v = r.f32_array::<6>()?;
        samples.push(Sample { x, y, theta: v[0], phi: v[1], dir: [v[2], v[3], v[4]], pdf: v[5] });
    }
    r.finish()?;
    Ok(Value::new(SampleSet { width, height, samples, luminance_integral }))
}
