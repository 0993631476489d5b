//! `hdrflow bench --bake`, part 1: the error of each level of a specular chain against
//! `exact: true`, for the estimators a user can pick: hdrflow's filtered importance sampling at
//! several sample counts, and plain Monte Carlo at the engines' tools' 1024 samples per texel
//! (every sample one bilinear read of the source: no filtered importance sampling).
//!
//! The exact reference sums the lobe over every source texel (`maths::ibl::zonal_sum`, as
//! `PrefilterSpecular(exact: true)` does), 6 S^2 texel pairs
//! per output texel: on a 256 source that is 0.4 M pairs a texel, so it is evaluated on a fixed
//! subset of each level's texels (`texels_per_level`, spread over every face by a stride with a
//! varying offset; all of a level when it has fewer), and each error is the RMS over that subset's
//! values of `(estimate - exact) / exact`, the measure of the prefilter tables of docs/src/benchmarks/ibl.md.

use std::time::Instant;

use rayon::prelude::*;

use hdrflow::geometry::cubemap as cube;
use hdrflow::maths::brdf::ggx::{points, LobeSequence};
use hdrflow::maths::brdf::specular_lobe::SpecularBrdf;
use hdrflow::maths::ibl::fis_kernel::PaddedPyramid;
use hdrflow::maths::ibl::prefilter::{
    exact_source_level, group_side, prefilter_level_exact, prefilter_level_fis, pyramid, zonal_lobe,
};
use hdrflow::maths::ibl::zonal_sum::ZonalSource;
use hdrflow::values::Cubemap;

/// An estimator of a chain's levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimator {
    /// filtered importance sampling with this many samples per texel
    Fis(usize),
    /// plain Monte Carlo with this many samples per texel, every read from level 0
    Plain(usize),
    /// what `PrefilterSpecular` does by default: the rough levels summed exactly over a
    /// coarser pyramid level (`rough_exact`), the others by filtered importance sampling, the
    /// sharp levels of large chains in texel groups sharing their reads (`prefilter::group_side`)
    Default(usize),
    /// filtered importance sampling with this many samples, every level in groups of this side
    /// where it divides the level (`maths::ibl::fis_group`)
    Grouped(usize, usize),
}

impl Estimator {
    pub fn label(self) -> String {
        match self {
            Estimator::Fis(n) => format!("FIS {n}"),
            Estimator::Plain(n) => format!("plain {n}"),
            Estimator::Default(n) => format!("hdrflow default ({n}; rough levels exact)"),
            Estimator::Grouped(n, g) => format!("FIS {n}, groups of {g} x {g}"),
        }
    }
}

/// The texels of a level of face size `size` the reference is evaluated at.
pub fn subset(size: usize, texels_per_level: usize) -> Vec<usize> {
    let count = 6 * size * size;
    if count <= texels_per_level {
        return (0..count).collect();
    }
    let stride = count.div_ceil(texels_per_level);
    (0..count / stride).map(|i| i * stride + (i * 7919) % stride).collect()
}

/// The exact prefiltered value at each texel of `texels` (indices into a level of face size
/// `size`), roughness `roughness`, from the source's texels.
pub fn exact_at(src: &ZonalSource, size: usize, roughness: f64, texels: &[usize]) -> Vec<[f32; 3]> {
    let lobe = zonal_lobe(SpecularBrdf::Ggx, roughness * roughness);
    texels
        .par_iter()
        .map(|&t| {
            let (f, y, x) = (t / (size * size), (t / size) % size, t % size);
            src.mean(cube::texel_direction(f, x, y, size), lobe)
        })
        .collect()
}

/// RMS over the values of `texels` of `(estimate - exact) / exact` (values with exact > 0).
pub fn rms_relative(level: &Cubemap, texels: &[usize], exact: &[[f32; 3]]) -> f64 {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (&t, e) in texels.iter().zip(exact) {
        let v = level.texel(t);
        for k in 0..3 {
            if e[k] > 0.0 {
                sum += ((v[k] as f64 - e[k] as f64) / e[k] as f64).powi(2);
                count += 1;
            }
        }
    }
    (sum / count.max(1) as f64).sqrt()
}

/// One estimator's chain: its seconds (levels 1 on; level 0 is the source) and its levels.
pub fn estimate(pyr: &[Cubemap], padded: &PaddedPyramid, roughness: &[f64], e: Estimator) -> (f64, Vec<Cubemap>) {
    let (n, filtered) = match e {
        Estimator::Fis(n) | Estimator::Default(n) | Estimator::Grouped(n, _) => (n, true),
        Estimator::Plain(n) => (n, false),
    };
    let pts = points(LobeSequence::Sobol, n);
    let t0 = Instant::now();
    let levels = roughness
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, &r)| {
            let size = (pyr[0].size >> k).max(1);
            match exact_source_level(&pyr.iter().map(|c| c.size).collect::<Vec<_>>(), size, r)
                .filter(|_| matches!(e, Estimator::Default(_)))
            {
                Some(m) => prefilter_level_exact(&pyr[m], size, r, SpecularBrdf::Ggx),
                None => {
                    let group = match e {
                        Estimator::Default(_) => group_side(size, r, SpecularBrdf::Ggx),
                        Estimator::Grouped(_, g) => g,
                        Estimator::Fis(_) | Estimator::Plain(_) => 1,
                    };
                    prefilter_level_fis(padded, size, r, &pts, SpecularBrdf::Ggx, filtered, group)
                }
            }
        })
        .collect();
    (t0.elapsed().as_secs_f64(), levels)
}

/// Per estimator: its time and the error of each level 1.. against the exact chain.
pub struct ChainErrors {
    pub estimator: Estimator,
    pub seconds: f64,
    pub errors: Vec<f64>,
}

/// The errors of every estimator of `estimators` on the chain of `src` with `roughness` per
/// level (level 0, the source itself, is left out), and the seconds the references took.
pub fn chain_errors(
    src: &Cubemap,
    roughness: &[f64],
    estimators: &[Estimator],
    texels_per_level: usize,
    log: &dyn Fn(&str),
) -> (Vec<ChainErrors>, f64) {
    let texels = ZonalSource::from_cube(src);
    let t0 = Instant::now();
    let references: Vec<(Vec<usize>, Vec<[f32; 3]>)> = roughness
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, &r)| {
            let size = (src.size >> k).max(1);
            let at = subset(size, texels_per_level);
            let exact = exact_at(&texels, size, r, &at);
            (at, exact)
        })
        .collect();
    let reference_seconds = t0.elapsed().as_secs_f64();
    log(&format!("exact references of {} levels: {reference_seconds:.1} s", references.len()));
    let pyr = pyramid(src);
    let padded = PaddedPyramid::new(&pyr.iter().collect::<Vec<_>>());
    let rows = estimators
        .iter()
        .map(|&e| {
            let (seconds, levels) = estimate(&pyr, &padded, roughness, e);
            let errors = levels.iter().zip(&references).map(|(l, (at, ex))| rms_relative(l, at, ex)).collect();
            log(&format!("{}: {seconds:.2} s", e.label()));
            ChainErrors { estimator: e, seconds, errors }
        })
        .collect();
    (rows, reference_seconds)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_subset_covers_every_face_once() {
        let s = subset(64, 1000);
        assert!(s.len() >= 900 && s.len() <= 1000, "{}", s.len());
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert!(s.iter().all(|&t| t < 6 * 64 * 64));
        for f in 0..6 {
            assert!(s.iter().any(|&t| t / (64 * 64) == f), "face {f}");
        }
        assert_eq!(subset(4, 1000).len(), 96);
    }

    /// On a constant source every estimator and the reference give 1: zero error.
    #[test]
    fn a_constant_source_has_no_error() {
        let mut c = Cubemap::new(8);
        c.data.iter_mut().for_each(|v| *v = 1.0);
        let r = [0.0, 0.3, 0.7];
        let (rows, _) = chain_errors(
            &c,
            &r,
            &[Estimator::Fis(64), Estimator::Plain(64), Estimator::Default(64), Estimator::Grouped(64, 2)],
            50,
            &|_| {},
        );
        for row in rows {
            assert!(row.errors.iter().all(|&e| e < 1e-5), "{:?}: {:?}", row.estimator, row.errors);
        }
    }
}
