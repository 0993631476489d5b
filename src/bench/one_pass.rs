//! The point targets' reference pass (`targets`, BuildCdf against one pass over the map's bytes):
//! the fastest read of every byte we have. One file for `hdrflow bench` (`bench::one_pass`) and
//! the criterion bench of the distribution (`benches/distribution.rs` includes it with `#[path]`).

use rayon::prelude::*;

/// One pass over every byte of `data` at memory bandwidth, on the same rayon pool as `BuildCdf`
/// (chunks of 64 Ki values, each summed into 16 independent f32 accumulators so that the
/// compiler vectorises it and no add waits on the previous one; the chunks' sums in f64).
pub fn one_pass(data: &[f32]) -> f64 {
    data.par_chunks(1 << 16)
        .map(|c| {
            let mut acc = [0.0f32; 16];
            let mut blocks = c.chunks_exact(16);
            for b in &mut blocks {
                for (a, v) in acc.iter_mut().zip(b) {
                    *a += v;
                }
            }
            let tail: f64 = blocks.remainder().iter().map(|&v| v as f64).sum();
            tail + acc.iter().map(|&a| a as f64).sum::<f64>()
        })
        .sum()
}
