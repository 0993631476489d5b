//! `Sample(cdf, count, seed, sequence: Random)`: directions drawn from an environment
//! distribution, each the centre of its texel with the texel's solid-angle pdf
//! (`maths::sampling::texel_samples`, where the formula and why texel centres are). Texel centres make
//! the estimators' expectation equal the exact sum over texels that `ReferenceSphere` computes.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::sampling::{sequences, texel_samples};
use crate::values::ty::*;
use crate::values::Distribution2D;

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
    Op::new("Sample", 1, "Draw directions from an environment distribution, with their solid-angle pdf", eval)
        .output("samples", SAMPLES_T, "the samples")
        .size(|_, p| p.cdf.size)
        .into()
}

fn eval(_: &mut OpContext, p: SampleParams) -> Result<Value, OpError> {
    let set = texel_samples::draw(&p.cdf, p.sequence, p.count, p.seed);
    Ok(Value::new(set))
}
