//! `maths::render::reference::reference_sphere`, the exact sum over every texel: a 256x256 sphere
//! against 1024x512 maps (target: a few seconds on 2 cores).
//!
//!     cargo bench --bench reference
//!
//! - `random`: a random map, one texel in five black (skipped by the packing) and a few very
//!   bright (the unit tests' `random_map`, seed 11);
//! - `sky`: the built-in sky resized to 1024x512 (a small sun, a smooth sky).
//!
//! Before measuring it prints, per map, the share of the written-out terms the kernels evaluate
//! after zero texels are skipped and tiles are culled (`reference_work`).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use hdrflow::geometry::latlong;
use hdrflow::maths::render::reference::{reference_sphere, reference_work};
use hdrflow::maths::render::relight::SphereView;
use hdrflow::maths::sampling::sequences::SplitMix64;
use hdrflow::values::Image;

/// A random map: one texel in five black, one in fifty at (500, 300, 100), the others random.
fn random_map(w: usize, h: usize, seed: u64) -> Image {
    let mut rng = SplitMix64::new(seed);
    let mut data = Vec::with_capacity(w * h * 3);
    for _ in 0..w * h {
        let r = rng.next_f64();
        let px = if r < 0.2 {
            [0.0; 3]
        } else if r > 0.98 {
            [500.0, 300.0, 100.0]
        } else {
            [rng.next_f64() as f32, rng.next_f64() as f32 * 2.0, rng.next_f64() as f32 * 0.1]
        };
        data.extend_from_slice(&px);
    }
    Image::from_vec(w, h, 3, data)
}

fn reference(c: &mut Criterion) {
    let view = SphereView::new(256, latlong::direction_deg(90.0, 90.0));
    let sky = hdrflow::formats::builtin::builtin("sky").expect("built-in");
    let maps = [
        ("random", random_map(1024, 512, 11)),
        ("sky", hdrflow::maths::resample::area_resize::resize(&sky, 1024, 512)),
    ];
    let mut group = c.benchmark_group("reference_sphere_256x256_on_1024x512");
    // One render takes seconds: the fewest samples criterion allows, one render each.
    group.sample_size(10);
    group.sampling_mode(SamplingMode::Flat);
    for (name, env) in &maps {
        let (evaluated, all) = reference_work(env, &view);
        eprintln!("{name}: {:.1}% of the {all} terms evaluated", 100.0 * evaluated as f64 / all as f64);
        group.bench_function(*name, |b| b.iter(|| black_box(reference_sphere(env, &view, [1.0; 3]))));
    }
    group.finish();
}

criterion_group!(benches, reference);
criterion_main!(benches);
