//! Tests of the layout resampling: footprints against brute force, energy kept, cube downsampling.
use super::*;
use crate::formats::builtin::builtin;

fn rel(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| ((a[k] - b[k]) / b[k]).abs()).fold(0.0, f64::max)
}

#[test]
fn constant_stays_constant() {
    let env = builtin("constant").unwrap();
    let c = to_cube(&LatLongSource::new(&env), 7);
    assert!(
        c.data.iter().all(|&v| (v - 1.0).abs() < 1e-6),
        "{:?}",
        c.data.iter().fold(0.0f32, |m, v| m.max((v - 1.0).abs()))
    );
    let back = to_latlong(&CubeSource::new(&c), 20, 10);
    assert!(back.data.iter().all(|&v| (v - 1.0).abs() < 1e-6));
    let oct = to_octahedral(&CubeSource::new(&c), 9);
    assert!(oct.data.iter().all(|&v| (v - 1.0).abs() < 1e-6));
    let i = cube_integral(&c);
    assert!((i[0] - 4.0 * PI).abs() < 1e-5 * 4.0 * PI, "{i:?}");
}

#[test]
fn energy_is_kept_on_the_sky() {
    let env = builtin("sky").unwrap();
    let want = latlong_integral(&env);
    let c = to_cube(&LatLongSource::new(&env), 48);
    let got = cube_integral(&c);
    assert!(rel(got, want) < 1e-3, "{got:?} vs {want:?}: {}", rel(got, want));
    let back = to_latlong(&CubeSource::new(&c), 256, 128);
    let got2 = latlong_integral(&back);
    assert!(rel(got2, got) < 1e-3, "{got2:?} vs {got:?}: {}", rel(got2, got));
    let oct = to_octahedral(&LatLongSource::new(&env), 128);
    let got3 = octahedral_integral(&oct);
    assert!(rel(got3, want) < 1e-3, "{got3:?} vs {want:?}: {}", rel(got3, want));
}

#[test]
fn downsample_keeps_energy() {
    let env = builtin("linear").unwrap();
    let c = to_cube(&LatLongSource::new(&env), 8);
    let d = downsample(&c);
    assert!(rel(cube_integral(&d), cube_integral(&c)) < 1e-6);
    let odd = to_cube(&LatLongSource::new(&env), 5);
    assert!(rel(cube_integral(&downsample(&odd)), cube_integral(&odd)) < 1e-3);
}
