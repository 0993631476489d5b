//! `Sample(cdf, count, seed, sequence: Random)`: directions drawn from an environment
//! distribution, each the centre of its texel with the texel's solid-angle pdf
//! `p(x, y) / ((2*pi/W) * (pi/H) * sin(theta))`. Texel centres (not points jittered inside the
//! texel) make the estimators' expectation equal the exact sum over texels of the
//! piecewise-constant map, which `ReferenceSphere` computes; and they let samples that land on
//! one texel be merged.

use rayon::prelude::*;

use crate::data::{Distribution2D, Sample, SampleSet};
use crate::engine::op::{FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;
use crate::maths::sequences;

use super::{count_field, sequence_of, SEED_FIELD, SEQUENCE_FIELD};

pub static SPEC: OpSpec = OpSpec {
    name: "Sample",
    category: "sampling",
    version: 1,
    doc: "Draw directions from an environment distribution, with their solid-angle pdf",
    fields: &[
        FieldSpec::input("cdf", &[ValueType::Distribution], "the distribution (BuildCdf)"),
        count_field(256),
        SEED_FIELD,
        SEQUENCE_FIELD,
    ],
    output: OutputType::Fixed(ValueType::Samples),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let set = draw(ctx.distribution("cdf"), sequence_of(ctx), ctx.params.usize("count"), ctx.params.int("seed") as u64);
    Ok(Value::Samples(std::sync::Arc::new(set)))
}

/// The operator's work, callable from code: `count` texel-centre samples of `dist`.
pub fn draw(dist: &Distribution2D, sequence: sequences::Sequence, count: usize, seed: u64) -> SampleSet {
    let points = sequences::generate(sequence, count, seed);
    let (w, h) = (dist.width, dist.height);
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
    SampleSet { width: w as u32, height: h as u32, samples }
}
