//! Shared-sample relighting: the whole 512x512 sphere under 1024 lights (`maths::render::relight`), and
//! the inner kernel on one hot tile, each SIMD kernel against the portable loop.
//!
//!     cargo bench --bench relight
//!
//! - `relight_512x512_1024_lights`: `relight` of a 512x512 sphere seen from (90, 90) under 1024
//!   Fibonacci-sphere lights (the target of `RelightSphere` 512x512 with 1024 samples: about
//!   20 ms on 2 cores, docs/src/benchmarks/point-targets.md).
//! - `kernel_wide_hot_tile`: `Kernel::accumulate_wide` over 16 wide blocks (256 lights) and 256
//!   normals, repeated; throughput in terms (normal, light lane) per second, so that each
//!   kernel's figure over `Scalar`'s is its speed-up. Kernels the CPU cannot run are left out
//!   (they would fall back to another one).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hdrflow::geometry::latlong;
use hdrflow::maths::render::kernels::{pack_blocks, wide_total, Kernel, WideSums, WIDE};
use hdrflow::maths::render::relight::{relight, LightSample, SphereView};

fn relight_sphere(c: &mut Criterion) {
    let lights: Vec<LightSample> = hdrflow::geometry::fibonacci_sphere(1024)
        .iter()
        .map(|d| LightSample { dir: d.map(|v| v as f32), weight: [1.0, 0.9, 0.8] })
        .collect();
    let view = SphereView::new(512, latlong::direction_deg(90.0, 90.0));
    let mut group = c.benchmark_group("relight_512x512_1024_lights");
    group.sample_size(20);
    group.bench_function("relight", |b| b.iter(|| black_box(relight(&view, &lights, [1.0; 3]))));
    group.finish();
}

/// The scalar loop and the kernel of every level above `portable` this CPU has (`portable`'s,
/// SSE2, runs the scalar loop in `accumulate_wide`).
fn kernels() -> Vec<Kernel> {
    let mut ks = vec![Kernel::Scalar];
    ks.extend(hdrflow::cpu::available_levels().into_iter().skip(1).map(Kernel::at));
    ks
}

fn kernel_hot_tile(c: &mut Criterion) {
    let lights: Vec<([f32; 3], [f32; 3])> =
        (0..256).map(|i| ([0.6, (i as f32 * 0.01).sin(), 0.8], [1.0, 0.5, 0.25])).collect();
    let mut blocks = Vec::new();
    pack_blocks::<WIDE>(lights, &mut blocks);
    let normals: Vec<[f32; 3]> = (0..256).map(|i| [0.0, (i as f32 * 0.003).cos(), (i as f32 * 0.003).sin()]).collect();
    let mut group = c.benchmark_group("kernel_wide_hot_tile");
    group.throughput(Throughput::Elements((normals.len() * blocks.len() * WIDE) as u64));
    for kernel in kernels() {
        let mut acc: Vec<WideSums> = vec![[[0.0f64; WIDE]; 3]; normals.len()];
        group.bench_function(format!("{kernel:?}"), |b| {
            b.iter(|| kernel.accumulate_wide(black_box(&blocks), black_box(&normals), &mut acc))
        });
        black_box(wide_total(&acc[0]));
    }
    group.finish();
}

criterion_group!(benches, relight_sphere, kernel_hot_tile);
criterion_main!(benches);
