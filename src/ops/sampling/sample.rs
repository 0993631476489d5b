//! `Sample(cdf, count, seed, sequence: Random)`: directions drawn from an environment
//! distribution, each the centre of its texel with the texel's solid-angle pdf
//! `p(x, y) / ((2*pi/W) * (pi/H) * sin(theta))`. Texel centres (not points jittered inside the
//! texel) make the estimators' expectation equal the exact sum over texels of the
//! piecewise-constant map, which `ReferenceSphere` computes; and they let samples that land on
//! one texel be merged.

use rayon::prelude::*;

use crate::engine::fields::{Check, Input};
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::maths::sequences;
use crate::values::ty::*;
use crate::values::{Distribution2D, Sample, SampleSet};

crate::params! {
    pub struct SampleParams {
        /// the distribution (BuildCdf)
        #[input(&[DISTRIBUTION_T])]
        pub cdf: Input<Distribution2D>,
        /// number of samples
        #[range(1, 1 << 24)]
        pub count: usize = 256,
        /// random seed: the same seed gives the same samples, whatever --jobs
        pub seed: u64 = 1,
        /// Random (seeded PCG), Stratified (jittered grid / Latin hypercube), Sobol (Owen-scrambled), Halton
        pub sequence: sequences::Sequence = sequences::Sequence::Random,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new("Sample", "sampling", 1, "Draw directions from an environment distribution, with their solid-angle pdf")
        .output("samples", OutputType::Fixed(SAMPLES_T), "the samples")
        .size(|_, p: SampleParams<Check>| p.cdf.size)
        .code_hash(crate::op_code_hash!())
        .eval(eval)
}

fn eval(_: &mut OpContext, p: SampleParams) -> Result<Value, OpError> {
    let set = draw(&p.cdf, p.sequence, p.count, p.seed);
    Ok(Value::new(set))
}

/// The operator's work, callable from code: `count` texel-centre samples of `dist`.
pub fn draw(dist: &Distribution2D, sequence: sequences::Sequence, count: usize, seed: u64) -> SampleSet {
    let points = sequences::generate(sequence, count, seed);
    let (w, h) = (dist.width(), dist.height());
    let samples: Vec<Sample> = points
        .par_iter()
        .map(|&[u1, u2]| {
            let (x, y, pdf) = dist.sample(u1, u2);
            let theta = latlong::theta_of_row(y, h);
            let phi = latlong::phi_of_column(x, w);
            let d = latlong::direction(theta, phi);
            Sample::new(x, y, theta, phi, d, pdf)
        })
        .collect();
    SampleSet {
        width: w as u32,
        height: h as u32,
        samples,
        luminance_integral: dist.carries_light().then_some(dist.luminance_integral()),
    }
}
