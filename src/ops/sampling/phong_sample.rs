//! `PhongSample(exponent, count, seed, normal, view, sequence, width, height)`: directions from
//! the modified Phong lobe (Lafortune and Willems 1994) around the mirror direction of `view`
//! about `normal`: cos(alpha) = u1^(1/(s+1)), phi = 2*pi*u2, pdf (s+1)/(2*pi) * cos^s(alpha).
//! Texel indices refer to a `width` x `height` lat-long grid, so `Overlay` can draw them.
//!
//! Defaults: normal and view both face forward (-Z, the centre column of a lat-long map), so
//! the lobe sits undistorted in the middle of the canvas, as in the seed's figures.

use rayon::prelude::*;

use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::maths::brdf::phong;
use crate::maths::sampling::sequences;
use crate::values::ty::*;
use crate::values::{Sample, SampleSet};

crate::params! {
    pub struct PhongSampleParams {
        /// Phong exponent s (0 = cosine-free uniform hemisphere lobe)
        #[range(0.0, 1e9)]
        pub exponent: f64,
        /// number of samples
        #[range(1, 1 << 24)]
        pub count: usize = 1024,
        /// random seed: the same seed gives the same samples, whatever --jobs
        pub seed: u64 = 1,
        /// surface normal (normalised here)
        #[range(-1e6, 1e6)]
        pub normal: [f64; 3] = [0.0, 0.0, -1.0],
        /// direction from the surface towards the viewer (normalised here)
        #[range(-1e6, 1e6)]
        pub view: [f64; 3] = [0.0, 0.0, -1.0],
        /// Random (seeded PCG), Stratified (jittered grid / Latin hypercube), Sobol (Owen-scrambled), Halton
        pub sequence: sequences::Sequence = sequences::Sequence::Random,
        /// lat-long grid width for texel indices
        #[range(1, 1 << 15)]
        pub width: usize = 512,
        /// lat-long grid height for texel indices
        #[range(1, 1 << 15)]
        pub height: usize = 256,
    }
}

pub fn spec() -> OpSpec {
    Op::new("PhongSample", 1, "Draw directions from a modified Phong lobe cos^s around the mirror direction", eval)
        .output("samples", SAMPLES_T, "the samples")
        .into()
}

fn normalised(v: [f64; 3], what: &str) -> Result<[f64; 3], OpError> {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if !(len > 1e-12) || !len.is_finite() {
        return Err(OpError::Invalid(format!("{what} must be a non-zero vector, got {v:?}")));
    }
    Ok(v.map(|c| c / len))
}

fn eval(_: &mut OpContext, p: PhongSampleParams) -> Result<Value, OpError> {
    let normal = normalised(p.normal, "normal")?;
    let view = normalised(p.view, "view")?;
    let axis = phong::mirror(view, normal);
    let s = p.exponent;
    let (w, h) = (p.width, p.height);
    let points = sequences::generate(p.sequence, p.count, p.seed);
    let samples: Vec<Sample> = points
        .par_iter()
        .map(|&[u1, u2]| {
            let (d, pdf) = phong::sample_lobe(axis, s, u1, u2);
            let (theta, phi) = latlong::angles(d);
            let (x, y) = latlong::texel_of_direction(d, w, h);
            Sample::new(x, y, theta, phi, d, pdf)
        })
        .collect();
    Ok(Value::new(SampleSet { width: w as u32, height: h as u32, samples, luminance_integral: None }))
}
