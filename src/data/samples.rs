//! `SampleSet`: directions drawn on the sphere, each with its solid-angle pdf.
//!
//! Direction convention (see `maths::latlong`): +Y up; a lat-long texel (x, y) of a W x H map has
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

/// An ordered set of samples with the lat-long grid their texel indices refer to.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleSet {
    pub width: u32,
    pub height: u32,
    pub samples: Vec<Sample>,
}
