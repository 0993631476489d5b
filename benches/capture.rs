//! `MergeBrackets`' core (`maths::capture::merge::merge`) on issue 38's size: 7 frames of
//! 6000 x 4000 8-bit RGB codes one stop apart (1/64 s to 1 s), merged with the sRGB response
//! and the hat weight, from frames already decoded (as OpenCV's `MergeDebevec` is timed: 9.7 s
//! there; the target is at most half). The frames are a smooth synthetic scene (a
//! radiance ramp over 14 stops with a texture), made once outside the timing; the codes are
//! the encoded exposure, so every frame has clipped, black and well-exposed regions. Variants:
//! the three weights and Consistency deghosting; then `AlignBrackets`' search (both pairings). `HDRFLOW_BENCH_SMALL=1` uses 1500 x 1000.
//!
//!     cargo bench --bench capture

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hdrflow::maths::capture::align::{bracket_shifts, Pairing};
use hdrflow::maths::capture::merge::{merge, Deghost, Weight};
use hdrflow::maths::capture::response::{Known, Response};
use hdrflow::values::brackets::{Brackets, Codes, Frame};

fn brackets(w: usize, h: usize) -> Brackets {
    let table: Vec<u8> = (0..4096).map(|i| (Known::Srgb.encode(i as f64 / 4095.0) * 255.0).round() as u8).collect();
    let frames = (0..7)
        .map(|f| {
            let t = 2f64.powi(f - 6);
            let codes = (0..w * h * 3)
                .map(|i| {
                    let (p, c) = (i / 3, i % 3);
                    let (x, y) = ((p % w) as f64 / w as f64, (p / w) as f64 / h as f64);
                    let stops = 14.0 * x - 10.0 + 0.5 * (37.0 * y + c as f64).sin();
                    let v = (2f64.powf(stops) * t).min(1.0);
                    table[(v * 4095.0) as usize]
                })
                .collect();
            Frame { name: format!("f{f}"), time: t, codes: Codes::U8(codes), covered: None }
        })
        .collect();
    Brackets::new(w, h, 8, frames).unwrap()
}

fn capture(c: &mut Criterion) {
    let (w, h) = if std::env::var_os("HDRFLOW_BENCH_SMALL").is_some() { (1500, 1000) } else { (6000, 4000) };
    let b = brackets(w, h);
    let r = Response::known(Known::Srgb, 8);
    let mut group = c.benchmark_group(format!("merge_brackets_7x{w}x{h}_8bit"));
    group.sample_size(10);
    group.throughput(Throughput::Elements((w * h) as u64));
    for (weight, deghost) in [
        (Weight::Hat, Deghost::None),
        (Weight::Gaussian, Deghost::None),
        (Weight::NoiseOptimal, Deghost::None),
        (Weight::Hat, Deghost::Consistency),
    ] {
        group.bench_function(format!("{weight}_{deghost}"), |bench| {
            bench.iter(|| black_box(merge(black_box(&b), &r, weight, deghost)).image.len())
        });
    }
    group.finish();
    // AlignBrackets' search on the same frames (both pairings), without moving them.
    let mut group = c.benchmark_group(format!("align_brackets_7x{w}x{h}_8bit"));
    group.sample_size(10);
    for pairing in [Pairing::Chained, Pairing::Reference] {
        group.bench_function(format!("{pairing:?}"), |bench| {
            bench.iter(|| black_box(bracket_shifts(black_box(&b), 64, pairing)).len())
        });
    }
    group.finish();
}

criterion_group!(benches, capture);
criterion_main!(benches);
