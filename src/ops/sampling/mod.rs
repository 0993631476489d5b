//! Building sampling distributions and drawing samples.

pub mod build_cdf;
pub mod phong_sample;
pub mod sample;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(&build_cdf::SPEC);
    r.register(&sample::SPEC);
    r.register(&phong_sample::SPEC);
}

use crate::engine::op::{Default, FieldKind, FieldSpec};

/// The fields every sampler shares: how many, which seed, which sequence.
pub(crate) const fn count_field(default: i64) -> FieldSpec {
    FieldSpec {
        name: "count",
        kind: FieldKind::Int { min: 1, max: 1 << 24 },
        default: Default::Int(default),
        doc: "number of samples",
    }
}
pub(crate) const SEED_FIELD: FieldSpec = FieldSpec {
    name: "seed",
    kind: FieldKind::Int { min: 0, max: i64::MAX },
    default: Default::Int(1),
    doc: "random seed: the same seed gives the same samples, whatever --jobs",
};
pub(crate) const SEQUENCE_FIELD: FieldSpec = FieldSpec {
    name: "sequence",
    kind: FieldKind::Choice(crate::maths::sequences::NAMES),
    default: Default::Choice("Random"),
    doc: "Random (seeded PCG), Stratified (jittered grid / Latin hypercube), Sobol (Owen-scrambled), Halton",
};

/// The sequence named by a validated `sequence` field.
pub(crate) fn sequence_of(ctx: &crate::engine::op::OpContext) -> crate::maths::sequences::Sequence {
    crate::maths::sequences::from_name(ctx.params.text("sequence")).expect("validated choice")
}
