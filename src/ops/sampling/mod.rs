//! Sampling: importance-sampling distributions and the samplers that draw from them.

pub mod build_cdf;
pub mod phong_sample;
pub mod sample;

use crate::engine::params::Choice;
use crate::engine::registry::Registry;
use crate::maths::sequences::Sequence;

pub fn register(r: &mut Registry) {
    r.register(build_cdf::spec());
    r.register(sample::spec());
    r.register(phong_sample::spec());
}

/// The low-discrepancy and random sequences as a pipeline choice (`sequence: Sobol`).
impl Choice for Sequence {
    const NAMES: &'static [&'static str] = crate::maths::sequences::NAMES;
    fn from_name(name: &str) -> Option<Self> {
        Sequence::ALL.iter().copied().find(|s| s.name() == name)
    }
    fn name(self) -> &'static str {
        Sequence::name(self)
    }
}

crate::choice_param!(Sequence);
