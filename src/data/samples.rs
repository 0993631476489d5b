//! `SampleSet`: directions drawn on the sphere, each with its solid-angle pdf.
//!
//! Direction convention (see `geometry::latlong`): +Y up; a lat-long texel (x, y) of a W x H map has
//! theta = pi*(y+0.5)/H (polar angle from +Y) and phi = 2*pi*(x+0.5)/W.

/// One sampled direction.
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
