//! What every pixel of a map reads ([`Scene`]): the lat-long tables, one record per texel and
//! the environment technique's texel sampler; and one pixel's estimate from them, in batches.

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::cpu;
use crate::geometry::latlong_grid::LatLongGrid;
use crate::maths::prefetch;
use crate::maths::sampling::guide_table::{GuidedDistribution, GuidedDraw};
use crate::maths::sampling::hierarchical_warp::{HierarchicalWarp, WarpDraw};
use crate::maths::sampling::mis::Heuristic;
use crate::values::{Distribution2D, Image};

use super::lanes::{
    band_point_batch, cosine_batch, cosine_in_basis, mis_batch, sample_uniform, CosineBatch, MisBatch, BATCH,
};
use super::uniforms::PixelUniforms;
use super::{PerPixelStrategy, PerPixelWarp};

/// What one texel offers a sample that lands in it: its radiance and the density (per
/// steradian) of the strategy's environment technique there. 16 bytes, so one cache line holds
/// four and a sample's texel costs one memory read. The density is stored as f32: a relative
/// rounding of 6e-8, which biases the estimate by at most that much (the f64 arithmetic around
/// it is unchanged).
#[derive(Clone, Copy, Debug, Default)]
struct TexelRecord {
    radiance: [f32; 3],
    pdf: f32,
}

/// What every pixel reads: the lat-long tables, the per-texel records and, when the strategy
/// draws from the distribution, its texel sampler (guide tables or the hierarchical warp).
pub(super) struct Scene<'a> {
    pub(super) env: &'a Image,
    grid: LatLongGrid,
    /// Empty for the strategies that need no density (`Cosine`, `Uniform`: they read `env`).
    records: Vec<TexelRecord>,
    /// How the environment technique draws its texel; `None` for `Cosine` and `Uniform`.
    texels: Option<TexelSampler<'a>>,
    /// The level the batch functions and the hierarchical descent run at (`cpu::level`).
    level: cpu::Level,
}

/// The environment technique's texel sampler, one per [`PerPixelWarp`].
enum TexelSampler<'a> {
    Guided(GuidedDistribution<'a>),
    Hierarchical(HierarchicalWarp),
}

/// A batch's texel draws between the stages of a [`TexelSampler`].
struct BatchDraws {
    guided: [GuidedDraw; BATCH],
    warp: [WarpDraw; BATCH],
}

impl TexelSampler<'_> {
    /// Stage 1 of sample `i`'s draw (prefetches what stage 2 reads).
    #[inline(always)]
    fn start(&self, draws: &mut BatchDraws, i: usize, u1: f64, u2: f64) {
        match self {
            TexelSampler::Guided(g) => draws.guided[i] = g.start(u1, u2),
            TexelSampler::Hierarchical(h) => draws.warp[i] = h.start(u1, u2),
        }
    }

    /// Stage 2 for the batch's first `count` draws (the hierarchical descent at `level`).
    #[inline(always)]
    fn resume(&self, level: cpu::Level, draws: &mut BatchDraws, count: usize) {
        match self {
            TexelSampler::Guided(g) => draws.guided[..count].iter_mut().for_each(|d| g.resume(d)),
            TexelSampler::Hierarchical(h) => h.descend_at(level, &mut draws.warp[..count]),
        }
    }

    /// Draw `i`'s texel and where it fell inside, `(x, y, rx, ry)` (uniform given the texel).
    #[inline(always)]
    fn finish(&self, draws: &BatchDraws, i: usize) -> (usize, usize, f64, f64) {
        match self {
            TexelSampler::Guided(g) => g.finish_continuous(&draws.guided[i]),
            TexelSampler::Hierarchical(h) => h.finish(&draws.warp[i]),
        }
    }

    /// Draw `i`'s texel alone (for the discrete `Environment` technique).
    #[inline(always)]
    fn finish_texel(&self, draws: &BatchDraws, i: usize) -> (usize, usize) {
        match self {
            TexelSampler::Guided(g) => g.finish(&draws.guided[i]),
            TexelSampler::Hierarchical(h) => {
                let (x, y, _, _) = h.finish(&draws.warp[i]);
                (x, y)
            }
        }
    }
}

impl<'a> Scene<'a> {
    /// Records hold the radiance and, for `Environment`, the midpoint density
    /// `P(texel) / dOmega_mid` (the pdf of `Distribution2D::sample`), for `Mis` the continuous
    /// technique's `P(texel) / dOmega_exact`; 0 where that is not a positive finite number.
    /// Built only for the strategies that draw from the distribution.
    pub(super) fn new(
        env: &'a Image,
        dist: &'a Distribution2D,
        strategy: PerPixelStrategy,
        warp: PerPixelWarp,
    ) -> Scene<'a> {
        let (w, h) = (env.width, env.height);
        let grid = LatLongGrid::new(w, h);
        let uses_distribution = strategy.uses_distribution();
        let mut records = vec![TexelRecord::default(); if uses_distribution { w * h } else { 0 }];
        records.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
            let solid_angle = match strategy {
                PerPixelStrategy::Environment => grid.midpoint_solid_angle(y),
                _ => grid.exact_solid_angle(y),
            };
            for (x, r) in row.iter_mut().enumerate() {
                let p = dist.texel_probability(x, y) / solid_angle;
                *r =
                    TexelRecord { radiance: env.rgb(x, y), pdf: if p.is_finite() && p > 0.0 { p as f32 } else { 0.0 } };
            }
        });
        let texels = uses_distribution.then(|| match warp {
            PerPixelWarp::Inversion => TexelSampler::Guided(GuidedDistribution::new(dist)),
            PerPixelWarp::Hierarchical => TexelSampler::Hierarchical(HierarchicalWarp::new(dist)),
        });
        Scene { env, grid, records, texels, level: cpu::level() }
    }

    #[inline]
    fn record(&self, x: usize, y: usize) -> &TexelRecord {
        &self.records[y * self.env.width + x]
    }

    /// Starts reading a texel's record early (a hint; no effect on results).
    #[inline(always)]
    fn prefetch_record(&self, (x, y): (usize, usize)) {
        prefetch(self.record(x, y));
    }

    /// One pixel's irradiance estimate `(1/spp) sum_j F_j` (see the module documentation) at
    /// unit normal `n`, in batches of [`BATCH`] samples, summed in sample order (`Mis`: each of
    /// the 16 lanes sums its samples in order, then the lanes are added in order). `spp == 0`
    /// gives zeros.
    #[allow(clippy::needless_range_loop)] // sample i of the batch arrays, in two stages
    pub(super) fn estimate_irradiance(
        &self,
        n: DVec3,
        strategy: PerPixelStrategy,
        heuristic: Heuristic,
        spp: usize,
        uniforms: &mut PixelUniforms,
    ) -> [f64; 3] {
        if spp == 0 {
            return [0.0; 3];
        }
        let mut sum = [0.0f64; 3];
        let mut add = |l: [f32; 3], k: f64| {
            for ch in 0..3 {
                sum[ch] += l[ch] as f64 * k;
            }
        };
        let (b1, b2) = n.any_orthonormal_pair();
        let mut dirs = [DVec3::ZERO; BATCH];
        let mut texels = [(0usize, 0usize); 2 * BATCH];
        let mut batch_uniforms = [[0.0f64; BATCH]; 4];
        let mut cosine = CosineBatch { basis: [n, b1, b2], u: [[0.0f64; BATCH]; 2], grid: &self.grid };
        let mut cosine_guesses = [[0.0f64; BATCH]; 2];
        let mut mis = MisBatch {
            normal: n,
            heuristic,
            dir: [[[0.0; BATCH]; 3]; 2],
            radiance: [[[0.0; BATCH]; 3]; 2],
            pdf: [[0.0; BATCH]; 2],
        };
        let mut lane_sums = [[0.0f64; BATCH]; 3];
        // Lanes past a short batch's count compute from zeros or stale values; unused.
        let (mut env_band, mut env_v) = ([[0.0f64; BATCH]; 3], [0.0f64; BATCH]);
        let mut draws = BatchDraws { guided: [GuidedDraw::default(); BATCH], warp: [WarpDraw::default(); BATCH] };
        for start in (0..spp).step_by(BATCH) {
            let count = BATCH.min(spp - start);
            // Stage 1: directions and the texels they fall in (no reads of the records). The
            // distribution's searches come first, alone in their loop, so that the batch's
            // cache misses overlap.
            match strategy {
                PerPixelStrategy::Environment => {
                    let sampler = self.texels.as_ref().expect("built for this strategy");
                    uniforms.batch(self.level, start, count, 1, &mut batch_uniforms);
                    for i in 0..count {
                        sampler.start(&mut draws, i, batch_uniforms[0][i], batch_uniforms[1][i]);
                    }
                    sampler.resume(self.level, &mut draws, count);
                    for i in 0..count {
                        texels[i] = sampler.finish_texel(&draws, i);
                        self.prefetch_record(texels[i]);
                    }
                    for i in 0..count {
                        dirs[i] = DVec3::from(self.grid.centre_direction(texels[i].0, texels[i].1));
                    }
                }
                PerPixelStrategy::Cosine | PerPixelStrategy::Uniform => {
                    uniforms.batch(self.level, start, count, 1, &mut batch_uniforms);
                    for i in 0..count {
                        let (u1, u2) = (batch_uniforms[0][i], batch_uniforms[1][i]);
                        dirs[i] = if strategy == PerPixelStrategy::Cosine {
                            cosine_in_basis(n, b1, b2, u1, u2)
                        } else {
                            sample_uniform(u1, u2)
                        };
                        texels[i] = self.grid.texel_of(dirs[i].to_array());
                    }
                }
                PerPixelStrategy::Mis => {
                    let sampler = self.texels.as_ref().expect("built for this strategy");
                    // The environment technique's texel search runs in stages between which
                    // the batch's reads are prefetched (see `GuidedDistribution::start`); the
                    // cosine technique's arithmetic fills the wait.
                    uniforms.batch(self.level, start, count, 2, &mut batch_uniforms);
                    for i in 0..count {
                        sampler.start(&mut draws, i, batch_uniforms[0][i], batch_uniforms[1][i]);
                    }
                    cosine.u = [batch_uniforms[2], batch_uniforms[3]];
                    // Cosine technique: the directions (arithmetic only, while the guide
                    // entries arrive) ...
                    cosine_batch(self.level, &cosine, &mut mis.dir[1], &mut cosine_guesses);
                    sampler.resume(self.level, &mut draws, count);
                    // ... and the texels containing them (while the CDF entries arrive).
                    for i in 0..count {
                        let guess = [cosine_guesses[0][i], cosine_guesses[1][i]];
                        let d = [mis.dir[1][0][i], mis.dir[1][1][i], mis.dir[1][2][i]];
                        texels[2 * i + 1] = self.grid.texel_from_guess(d, guess);
                        self.prefetch_record(texels[2 * i + 1]);
                    }
                    for i in 0..count {
                        // Environment technique: the texel and, from where (u1, u2) fell in
                        // it, a point uniform in solid angle inside it.
                        let (x, y, rx, ry) = sampler.finish(&draws, i);
                        texels[2 * i] = (x, y);
                        self.prefetch_record((x, y));
                        let (c0, c1) = self.grid.row_edges_cos(y);
                        [env_band[0][i], env_band[1][i], env_band[2][i]] = [self.grid.turns_in_column(x, rx), c0, c1];
                        env_v[i] = ry;
                    }
                    band_point_batch(self.level, &env_band, &env_v, &mut mis.dir[0]);
                    // Stage 2: the records, then the weights and sums lane by lane.
                    for i in 0..count {
                        for t in 0..2 {
                            let r = self.record(texels[2 * i + t].0, texels[2 * i + t].1);
                            [mis.radiance[t][0][i], mis.radiance[t][1][i], mis.radiance[t][2][i]] = r.radiance;
                            mis.pdf[t][i] = r.pdf;
                        }
                    }
                    mis_batch(self.level, &mis, count, &mut lane_sums);
                }
            }
            // Stage 2: read the texels' records and accumulate, in sample order.
            for i in 0..count {
                match strategy {
                    PerPixelStrategy::Environment => {
                        let r = self.record(texels[i].0, texels[i].1);
                        if r.pdf > 0.0 {
                            add(r.radiance, n.dot(dirs[i]).max(0.0) / r.pdf as f64);
                        }
                    }
                    // f / p = L cos / (cos / pi) = pi L.
                    PerPixelStrategy::Cosine => add(self.env.rgb(texels[i].0, texels[i].1), PI),
                    PerPixelStrategy::Uniform => {
                        add(self.env.rgb(texels[i].0, texels[i].1), 4.0 * PI * n.dot(dirs[i]).max(0.0))
                    }
                    // Accumulated in stage 1's arm, lane by lane.
                    PerPixelStrategy::Mis => {}
                }
            }
        }
        // Mis's lane sums, in lane order (each lane summed its samples in order).
        for lane in 0..BATCH {
            for ch in 0..3 {
                sum[ch] += lane_sums[ch][lane];
            }
        }
        sum.map(|s| s / spp as f64)
    }
}
