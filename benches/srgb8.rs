//! The 8-bit sRGB code of linear values: `formats::srgb8::Srgb8Table` (a binary search over the
//! 255 steps) against the exact function it replaces (`formats::png::linear_to_srgb8`, a
//! `powf`), on the same 2^20 values: every 1016th f32 bit pattern in [0, 1], the range the
//! table's exhaustive test covers. Throughput in codes per second: the table's figure over the
//! exact one's is its speed-up.
//!
//!     cargo bench --bench srgb8

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hdrflow::formats::png::linear_to_srgb8;
use hdrflow::formats::srgb8::Srgb8Table;

fn srgb8(c: &mut Criterion) {
    let end = 1.0f32.to_bits();
    let values: Vec<f64> = (0..1u32 << 20).map(|i| f32::from_bits((i * (end / (1 << 20))).min(end)) as f64).collect();
    let table = Srgb8Table::new();
    let mut group = c.benchmark_group("srgb8_code_of_2^20_values_in_0_1");
    group.throughput(Throughput::Elements(values.len() as u64));
    group.bench_function("table", |b| b.iter(|| black_box(&values).iter().map(|&v| table.code(v) as u64).sum::<u64>()));
    group.bench_function("exact", |b| {
        b.iter(|| black_box(&values).iter().map(|&v| linear_to_srgb8(v) as u64).sum::<u64>())
    });
    group.finish();
}

criterion_group!(benches, srgb8);
criterion_main!(benches);
