//! Texel-centre samples of an environment distribution: each direction is the centre of the
//! texel the distribution picks, with the texel's solid-angle pdf
//! `p(x, y) / ((2*pi/W) * (pi/H) * sin(theta))`. Texel centres (not points jittered inside the
//! texel) make the estimators' expectation equal the exact sum over texels of the
//! piecewise-constant map, which `maths::render::reference` computes; and they let samples that land on
//! one texel be merged (`maths::render::relight::merge_duplicates`).

use rayon::prelude::*;

use crate::geometry::latlong;
use crate::maths::sampling::sequences;
use crate::values::{Distribution2D, Sample, SampleSet};

/// `count` texel-centre samples of `dist`, from `count` points of `sequence` with `seed` (the
/// same seed gives the same samples, whatever the thread count). The set carries the
/// distribution's luminance integral when it was built from a map (the seed's estimator scales
/// by it).
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
