//! The 8-bit sRGB code of linear values: `formats::srgb8::Srgb8Table` (a binary search over the
//! 255 steps) against the exact function it replaces (`formats::srgb8::linear_to_srgb8`, a
//! `powf` above the linear segment), on the same 2^20 values, uniform in [0, 1) in random order
//! (SplitMix64, seed 1), as an exposed image's values mostly are: almost all on the power
//! segment, where the exact function pays its `powf`. (Spread evenly over the f32 bit patterns
//! instead, most values would fall on the linear segment, c <= 0.0031308, which costs the exact
//! function no `powf`.) Throughput in codes per second: the table's figure over the exact one's
//! is its speed-up.
//!
//!     cargo bench --bench srgb8

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hdrflow::formats::srgb8::linear_to_srgb8;
use hdrflow::formats::srgb8::Srgb8Table;
use hdrflow::maths::sampling::sequences::SplitMix64;

fn srgb8(c: &mut Criterion) {
    let mut rng = SplitMix64::new(1);
    let values: Vec<f64> = (0..1 << 20).map(|_| rng.next_f64() as f32 as f64).collect();
    let table = Srgb8Table::new();
    let mut group = c.benchmark_group("srgb8_code_of_2^20_uniform_values_in_0_1");
    group.throughput(Throughput::Elements(values.len() as u64));
    group.bench_function("table", |b| b.iter(|| black_box(&values).iter().map(|&v| table.code(v) as u64).sum::<u64>()));
    group.bench_function("exact", |b| {
        b.iter(|| black_box(&values).iter().map(|&v| linear_to_srgb8(v) as u64).sum::<u64>())
    });
    group.finish();
}

criterion_group!(benches, srgb8);
criterion_main!(benches);
