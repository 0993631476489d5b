//! `maths::render::glossy`: `GlossySphere`'s three strategies (power heuristic for `Mis`) at 128x128 and
//! 64 spp, and the exact `ReferenceGlossySphere`, on the built-in sky (512x256), Phong exponent
//! 50 (diffuse (0.2, 0.15, 0.1), specular 0.6: the unit tests' BRDF).
//!
//!     cargo bench --bench glossy

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use hdrflow::colour::rec709_luminance_f32;
use hdrflow::geometry::latlong;
use hdrflow::maths::render::glossy::{glossy_sphere, reference_glossy_sphere, GlossyBrdf, GlossyStrategy, Heuristic};
use hdrflow::maths::render::relight::SphereView;
use hdrflow::values::{Distribution2D, Image};

/// The sin(theta)-weighted distribution of the map's Rec. 709 luminance.
fn luminance_distribution(env: &Image) -> Distribution2D {
    let lum: Vec<f32> = (0..env.height)
        .flat_map(|y| (0..env.width).map(move |x| (x, y)))
        .map(|(x, y)| rec709_luminance_f32(env.rgb(x, y)))
        .collect();
    Distribution2D::build(&Image::from_vec(env.width, env.height, 1, lum), true, false).expect("a finite map")
}

fn glossy(c: &mut Criterion) {
    let sky = hdrflow::formats::builtin::builtin("sky").expect("built-in");
    let dist = luminance_distribution(&sky);
    let view = SphereView::new(128, latlong::direction_deg(90.0, 90.0));
    let brdf = GlossyBrdf { diffuse: [0.2, 0.15, 0.1], specular: [0.6, 0.6, 0.6], exponent: 50.0 };
    let mut group = c.benchmark_group("glossy_128x128_on_sky_512x256");
    group.sample_size(10);
    group.sampling_mode(SamplingMode::Flat);
    for strategy in GlossyStrategy::ALL {
        group.bench_function(format!("{strategy:?}_64spp"), |b| {
            b.iter(|| black_box(glossy_sphere(&sky, &dist, &view, &brdf, strategy, Heuristic::Power, 64, 1)))
        });
    }
    group.bench_function("reference", |b| b.iter(|| black_box(reference_glossy_sphere(&sky, &view, &brdf))));
    group.finish();
}

criterion_group!(benches, glossy);
criterion_main!(benches);
