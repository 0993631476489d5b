//! `maths::render::per_pixel`: every per-pixel strategy with each sequence, a 128x128 sphere at
//! 1024 spp (the benchmark's largest per-pixel point), on Grace Cathedral from ../shared when
//! present (flipped, as `hdrflow bench` loads it), else the built-in sky. Each render includes
//! building the strategy's records and tables (`relight_per_pixel_with`).
//!
//!     cargo bench --bench per_pixel                       # every configuration
//!     cargo bench --bench per_pixel -- 'Mis/Random'       # one (criterion's filter)
//!
//! Environment variables: `HDRFLOW_PER_PIXEL_MAP=path` (.exr or .hdr) times another map,
//! `HDRFLOW_PER_PIXEL_POWER=1` uses the power heuristic (Mitsuba's `direct`) for `Mis`,
//! `HDRFLOW_PER_PIXEL_WARP=Hierarchical` the hierarchical warp.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use hdrflow::colour::rec709_luminance_f32;
use hdrflow::geometry::latlong;
use hdrflow::maths::render::glossy::Heuristic;
use hdrflow::maths::render::per_pixel::{
    relight_per_pixel_with, PerPixelOptions, PerPixelSequence, PerPixelStrategy, PerPixelWarp,
};
use hdrflow::maths::render::relight::SphereView;
use hdrflow::values::{Distribution2D, Image};

/// The map: `HDRFLOW_PER_PIXEL_MAP`, else Grace Cathedral, else the built-in sky.
fn map() -> (String, Image) {
    let grace = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/envmaps/grace_latlong.exr");
    let path = std::env::var_os("HDRFLOW_PER_PIXEL_MAP").map(PathBuf::from).unwrap_or(grace);
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("exr").to_lowercase();
    match std::fs::read(&path) {
        Ok(bytes) => {
            let env = hdrflow::formats::decode_by_extension(&bytes, &ext).expect("a readable map").flipped_vertical();
            (path.display().to_string(), env)
        }
        Err(_) => ("the built-in sky".into(), hdrflow::formats::builtin::builtin("sky").expect("built-in")),
    }
}

/// The sin(theta)-weighted distribution of the map's Rec. 709 luminance.
fn luminance_distribution(env: &Image) -> Distribution2D {
    let lum: Vec<f32> = (0..env.height)
        .flat_map(|y| (0..env.width).map(move |x| (x, y)))
        .map(|(x, y)| rec709_luminance_f32(env.rgb(x, y)))
        .collect();
    let lum = Image::from_vec(env.width, env.height, 1, lum);
    Distribution2D::build(&lum, true, false).expect("a finite map")
}

fn per_pixel(c: &mut Criterion) {
    let (name, env) = map();
    eprintln!("per-pixel strategies on {name} ({}x{})", env.width, env.height);
    let dist = luminance_distribution(&env);
    let view = SphereView::new(128, latlong::direction_deg(90.0, 90.0));
    let heuristic =
        if std::env::var_os("HDRFLOW_PER_PIXEL_POWER").is_some() { Heuristic::Power } else { Heuristic::Balance };
    let warp = std::env::var("HDRFLOW_PER_PIXEL_WARP")
        .ok()
        .and_then(|w| PerPixelWarp::from_name_ignore_case(&w))
        .unwrap_or(PerPixelWarp::Inversion);
    let mut group = c.benchmark_group("per_pixel_128x128_1024spp");
    // One render takes a second or more: the fewest samples criterion allows, one render each.
    group.sample_size(10);
    group.sampling_mode(SamplingMode::Flat);
    for strategy in PerPixelStrategy::ALL {
        for sequence in PerPixelSequence::ALL {
            let options = PerPixelOptions { strategy, sequence, heuristic, warp, spp: 1024, seed: 1 };
            group.bench_function(format!("{strategy:?}/{sequence:?}"), |b| {
                b.iter(|| black_box(relight_per_pixel_with(&env, &dist, &view, [0.8; 3], &options)))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, per_pixel);
criterion_main!(benches);
