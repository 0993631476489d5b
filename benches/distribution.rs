//! `values::distribution`: `Distribution2D::build` (BuildCdf) of a random 2048x1024 luminance
//! map, the size where its point target ("within 3x of one pass over the map's bytes",
//! docs/src/benchmarks/point-targets.md) is tightest, against two passes over the same texels:
//!
//! - `rgb_pass`: one parallel read of the RGB f32 map the luminance comes from, the target's
//!   reference at memory bandwidth (`one_pass`, the same function as `hdrflow bench`'s);
//! - `convert_and_write`: the floor of the distribution's layout, each luminance texel converted
//!   to f64 and written once into a fresh buffer of the conditional CDFs' size, `h (w + 1)` f64.
//!
//! Throughput in texels per second. The build runs the row kernel of `cpu::level` (the widest
//! this processor has, or `HDRFLOW_CPU`'s): the kernels are crate-private, and the distribution's
//! tests check that each gives the portable kernel's bits.
//!
//!     cargo bench --bench distribution

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hdrflow::maths::sampling::sequences::SplitMix64;
use hdrflow::values::{Distribution2D, Image};
use rayon::prelude::*;

#[path = "../src/bench/one_pass.rs"]
mod one_pass;
use one_pass::one_pass;

/// A one-channel map of values in [0, 10), about a fifth of them zero (the distribution tests'
/// random map).
fn random_map(w: usize, h: usize, seed: u64) -> Image {
    let mut rng = SplitMix64::new(seed);
    let data = (0..w * h).map(|_| if rng.next_f64() < 0.2 { 0.0 } else { (10.0 * rng.next_f64()) as f32 }).collect();
    Image::from_vec(w, h, 1, data)
}

/// `luminance` converted to f64 into a fresh buffer laid out as the conditional CDFs are (`w + 1`
/// entries a row, the last left unwritten), rows in parallel.
fn convert_and_write(luminance: &Image) -> Vec<f64> {
    let w = luminance.width;
    let entries = luminance.height * (w + 1);
    let mut out: Vec<f64> = Vec::with_capacity(entries);
    out.spare_capacity_mut()[..entries].par_chunks_mut(w + 1).zip(luminance.data.par_chunks(w)).for_each(|(o, s)| {
        for (o, &x) in o.iter_mut().zip(s) {
            o.write(x as f64);
        }
    });
    out
}

fn build_cdf(c: &mut Criterion) {
    let (w, h) = (2048, 1024);
    let luminance = random_map(w, h, 7);
    let rgb: Vec<f32> = luminance.data.iter().flat_map(|&v| [v, 0.5 * v, 2.0 * v]).collect();
    let mut group = c.benchmark_group(format!("build_cdf_{w}x{h}"));
    group.throughput(Throughput::Elements((w * h) as u64));
    group.bench_function("build", |b| {
        b.iter(|| black_box(Distribution2D::build(black_box(&luminance), true, false).expect("a valid map")))
    });
    group.bench_function("rgb_pass", |b| b.iter(|| black_box(one_pass(black_box(&rgb)))));
    group.bench_function("convert_and_write", |b| b.iter(|| black_box(convert_and_write(black_box(&luminance)))));
    group.finish();
}

criterion_group!(benches, build_cdf);
criterion_main!(benches);
