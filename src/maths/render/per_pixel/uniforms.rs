//! Where a pixel's uniforms come from ([`PerPixelSequence`]): its SplitMix64 stream, or Sobol
//! points scrambled from it, drawn a batch at a time.

use crate::maths::sampling::sequences::{bits_to_unit, nested_uniform_scramble, sobol_2d_bits, unit_f64, SplitMix64};

use crate::cpu;

use super::lanes::BATCH;
use super::PerPixelSequence;

/// One pixel's source of 2D uniforms (see [`PerPixelSequence`]).
pub(super) struct PixelUniforms {
    rng: SplitMix64,
    /// Per 2D request k: (index shuffle seed, x scramble seed, y scramble seed); `None` for
    /// `Random`.
    sobol: Option<[[u32; 3]; 2]>,
}

impl PixelUniforms {
    pub(super) fn new(sequence: PerPixelSequence, seed: u64) -> PixelUniforms {
        let mut rng = SplitMix64::new(seed);
        let sobol = match sequence {
            PerPixelSequence::Random => None,
            PerPixelSequence::Sobol => {
                let mut seeds = [[0u32; 3]; 2];
                for s in seeds.iter_mut().flatten() {
                    *s = (rng.next_u64() >> 32) as u32;
                }
                Some(seeds)
            }
        };
        PixelUniforms { rng, sobol }
    }

    /// The uniforms of samples `start + i` for `i < count` (at most [`BATCH`]), requests
    /// `k < requests` (1 or 2) of each, into `out[2k][i], out[2k + 1][i]`. Request 0 chooses the
    /// texel (and, for `Mis`, the point inside it): 53-bit uniforms, so that every texel of
    /// positive probability can be drawn; request 1 chooses a direction around the normal, where
    /// 32 bits (2.3e-10) are far finer than any texel, so `Random` takes both from one 64-bit
    /// draw. Each sample draws its requests in order, then the next sample, and the pixel's
    /// generator advances by the `count` samples' draws. Lanes past `count` are filled too (a
    /// fixed-length loop vectorises; they are unused). `level` chooses the compilation
    /// ([`cpu::dispatch!`]).
    #[inline(always)]
    pub(super) fn batch(
        &mut self,
        level: cpu::Level,
        start: usize,
        count: usize,
        requests: usize,
        out: &mut [[f64; BATCH]; 4],
    ) {
        let lanes = UniformLanes { rng: &self.rng, sobol: self.sobol, start, requests };
        uniform_batch(level, &lanes, out);
        self.rng.skip((count * lanes.draws_per_sample()) as u64);
    }
}

/// What [`uniform_lanes`] computes from: the pixel's generator (read, not advanced), its Sobol
/// scrambles and the batch's first sample and request count.
struct UniformLanes<'r> {
    rng: &'r SplitMix64,
    sobol: Option<[[u32; 3]; 2]>,
    start: usize,
    requests: usize,
}

impl UniformLanes<'_> {
    /// 64-bit draws per sample: `Random` takes two for request 0 and one for request 1, `Sobol`
    /// one per request (the low bits below its 32 Sobol bits).
    #[inline(always)]
    fn draws_per_sample(&self) -> usize {
        match self.sobol {
            None => 2 + (self.requests > 1) as usize,
            Some(_) => self.requests,
        }
    }
}

/// [`PixelUniforms::batch`]'s values, lane by lane, as a plain loop (see
/// [`cosine_batch_lanes`](super::lanes)).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane i of several arrays
fn uniform_lanes(lanes: &UniformLanes, out: &mut [[f64; BATCH]; 4]) {
    let per_sample = lanes.draws_per_sample();
    let both = lanes.requests > 1;
    match lanes.sobol {
        None => {
            for i in 0..BATCH {
                let r = (i * per_sample) as u64;
                out[0][i] = unit_f64(lanes.rng.peek(r));
                out[1][i] = unit_f64(lanes.rng.peek(r + 1));
                if both {
                    let v = lanes.rng.peek(r + 2);
                    out[2][i] = bits_to_unit((v >> 32) as u32);
                    out[3][i] = bits_to_unit(v as u32);
                }
            }
        }
        Some(seeds) => {
            let fill = |bits: u32, low21: u64| (((bits as u64) << 21) | low21) as f64 * (1.0 / (1u64 << 53) as f64);
            for i in 0..BATCH {
                let j = (lanes.start + i) as u32;
                for (k, &[shuffle, sx, sy]) in seeds.iter().enumerate().take(lanes.requests) {
                    let [x, y] = sobol_2d_bits(nested_uniform_scramble(j, shuffle));
                    let low = lanes.rng.peek((i * per_sample + k) as u64);
                    out[2 * k][i] = fill(nested_uniform_scramble(x, sx), low & 0x1F_FFFF);
                    out[2 * k + 1][i] = fill(nested_uniform_scramble(y, sy), (low >> 21) & 0x1F_FFFF);
                }
            }
        }
    }
}

cpu::dispatch! {
    #[levels(Avx512)]
    /// [`uniform_lanes`], compiled for AVX-512 and the baseline.
    #[inline(always)]
    fn uniform_batch(lanes: &UniformLanes, out: &mut [[f64; BATCH]; 4]) = uniform_lanes;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::render::per_pixel::pixel_seed;

    /// Sample `j`'s request `k`, drawn one sample at a time as the batches' documentation
    /// describes (the reference [`PixelUniforms::batch`] is checked against).
    fn sequential_pair(u: &mut PixelUniforms, j: usize, k: usize) -> [f64; 2] {
        match &u.sobol {
            None if k == 0 => [u.rng.next_f64(), u.rng.next_f64()],
            None => {
                let r = u.rng.next_u64();
                [bits_to_unit((r >> 32) as u32), bits_to_unit(r as u32)]
            }
            Some(seeds) => {
                let [shuffle, sx, sy] = seeds[k];
                let [x, y] = sobol_2d_bits(nested_uniform_scramble(j as u32, shuffle));
                let low = u.rng.next_u64();
                let fill = |bits: u32, low21: u64| (((bits as u64) << 21) | low21) as f64 * (1.0 / (1u64 << 53) as f64);
                [
                    fill(nested_uniform_scramble(x, sx), low & 0x1F_FFFF),
                    fill(nested_uniform_scramble(y, sy), (low >> 21) & 0x1F_FFFF),
                ]
            }
        }
    }

    /// Batches (at every level the processor has) give the sequential draws' bits, full and
    /// short, with one request or two, and leave the generator where the sequential draws leave
    /// it.
    #[test]
    #[allow(clippy::needless_range_loop)] // lane i of several arrays
    fn batches_match_the_sequential_draws() {
        let levels = cpu::tested_levels();
        for sequence in PerPixelSequence::ALL {
            for requests in [1, 2] {
                for &level in &levels {
                    let mut batched = PixelUniforms::new(sequence, pixel_seed(7, 3));
                    let mut sequential = PixelUniforms::new(sequence, pixel_seed(7, 3));
                    let mut start = 0;
                    for count in [16, 16, 5, 16, 1] {
                        let mut out = [[0.0; BATCH]; 4];
                        batched.batch(level, start, count, requests, &mut out);
                        for i in 0..count {
                            for k in 0..requests {
                                let want = sequential_pair(&mut sequential, start + i, k);
                                let got = [out[2 * k][i], out[2 * k + 1][i]];
                                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{sequence:?} {k} {level}");
                            }
                        }
                        assert_eq!(batched.rng, sequential.rng);
                        start += count;
                    }
                }
            }
        }
    }

    /// Both sequences give values in [0, 1); Sobol's first 2^m points of a request, per pixel,
    /// put exactly one point in each of the 2^m columns (a (0, m, 2)-net's 1D projection).
    #[test]
    fn sobol_uniforms_are_stratified_per_pixel() {
        let draw = |sequence, pixel, samples: usize| {
            let mut u = PixelUniforms::new(sequence, pixel_seed(3, pixel));
            let mut pairs = vec![[[0.0; 2]; 2]; samples];
            for start in (0..samples).step_by(BATCH) {
                let mut out = [[0.0; BATCH]; 4];
                let count = BATCH.min(samples - start);
                u.batch(cpu::level(), start, count, 2, &mut out);
                for i in 0..count {
                    pairs[start + i] = [[out[0][i], out[1][i]], [out[2][i], out[3][i]]];
                }
            }
            pairs
        };
        for pixel in 0..20u64 {
            let pairs = draw(PerPixelSequence::Sobol, pixel, 64);
            for k in 0..2 {
                let mut columns = [0usize; 64];
                let mut rows = [0usize; 64];
                for [a, b] in pairs.iter().map(|p| p[k]) {
                    assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
                    columns[(a * 64.0) as usize] += 1;
                    rows[(b * 64.0) as usize] += 1;
                }
                assert!(columns.iter().chain(&rows).all(|&c| c == 1), "pixel {pixel} request {k}");
            }
        }
        let pairs = draw(PerPixelSequence::Random, 1, 1000);
        assert!(pairs.iter().flatten().flatten().all(|v| (0.0..1.0).contains(v)));
    }
}
