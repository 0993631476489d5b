//! The cut-cell rotation against a brute-force footprint mean, the adaptive midpoint subdivision
//! it replaces, and the sphere integral.

use std::f64::consts::PI;

use glam::DVec3;

const SQUARE: crate::maths::resample::polygon::Poly<6> = crate::maths::resample::polygon::Poly::SQUARE;
use super::*;
use crate::geometry::latlong;
use crate::geometry::rotation::Rotation;
use crate::maths::resample::layouts::{latlong_integral, to_latlong_precise};
use crate::maths::resample::rotation::Rotated;

/// Texel noise in [0.5, 1.5] (every neighbour differs: the hardest case for a quadrature of
/// piecewise-constant maps), with a 2 x 2 texel block 1000 times brighter, a "sun".
fn noise_map(w: usize, h: usize) -> Image {
    let mut data: Vec<f32> =
        (0..w * h * 3).map(|i| 0.5 + ((i * 7919 + i / 3 * 104729) % 1009) as f32 / 1009.0).collect();
    for (x, y) in [(w / 3, h / 3), (w / 3 + 1, h / 3), (w / 3, h / 3 + 1), (w / 3 + 1, h / 3 + 1)] {
        for k in 0..3 {
            data[(y * w + x) * 3 + k] *= 1000.0;
        }
    }
    Image::from_vec(w, h, 3, data)
}

/// The brute-force footprint mean of output texel (x, y): n x n cells in (phi, theta), each
/// weighted by its exact solid angle, taking the source texel at its centre.
fn brute_force(img: &Image, r: Rotation, x: usize, y: usize, n: usize) -> [f64; 3] {
    let (w, h) = (img.width, img.height);
    let inverse = r.0.transpose();
    let (dp, dq) = (2.0 * PI / w as f64 / n as f64, PI / h as f64 / n as f64);
    let (mut acc, mut weight) = ([0.0; 3], 0.0);
    for j in 0..n {
        let q0 = PI * y as f64 / h as f64 + dq * j as f64;
        let omega = dp * (q0.cos() - (q0 + dq).cos());
        for i in 0..n {
            let p = 2.0 * PI * x as f64 / w as f64 + dp * (i as f64 + 0.5);
            let s = inverse * DVec3::from(latlong::direction(q0 + 0.5 * dq, p));
            let (sx, sy) = latlong::texel_of_direction(s.into(), w, h);
            let v = img.pixel(sx, sy);
            for k in 0..3 {
                acc[k] += v[k] as f64 * omega;
            }
            weight += omega;
        }
    }
    acc.map(|a| a / weight)
}

/// The largest and mean relative difference of `got` from `want` on the probed texels.
fn errors(got: &Image, want: &[((usize, usize), [f64; 3])]) -> (f64, f64) {
    let (mut worst, mut sum) = (0.0f64, 0.0);
    for &((x, y), v) in want {
        let p = got.pixel(x, y);
        for k in 0..3 {
            let e = (p[k] as f64 - v[k]).abs() / v[k];
            worst = worst.max(e);
            sum += e / (3 * want.len()) as f64;
        }
    }
    (worst, sum)
}

#[test]
fn agrees_with_a_brute_force_footprint_mean_as_closely_as_the_midpoint_subdivision() {
    let (w, h) = (48, 24);
    let img = noise_map(w, h);
    let src = LatLongSource::new(&img);
    let probes: Vec<(usize, usize)> = (0..24).map(|i| ((i * 37 + 5) % w, (i * 11 + i / 5) % h)).collect();
    {
        let r = Rotation::from_yaw_pitch_roll(33.0, 21.0, -12.0);
        let want: Vec<_> = probes.iter().map(|&(x, y)| ((x, y), brute_force(&img, r, x, y, 512))).collect();
        let new = rotated_latlong(&src, r.0.transpose(), ROTATION_TOLERANCE, 12);
        let old = to_latlong_precise(&Rotated::new(&src, r), w, h, 1e-9, 12);
        let (new_worst, new_mean) = errors(&new, &want);
        let (old_worst, old_mean) = errors(&old, &want);
        eprintln!("{r:?}: cut cells worst {new_worst:.2e} mean {new_mean:.2e}; midpoint worst {old_worst:.2e} mean {old_mean:.2e}");
        // Measured: cut cells worst 4.2e-5, mean 8.8e-6 (6.6e-5 and 1.1e-5 before long cells were
        // halved across their length only); midpoint worst 4.8e-4, mean 3.5e-5 (the
        // brute force's own error, 1/512 of a texel per cell on the boundaries, is about 1e-5).
        assert!(
            new_worst < 1e-4 && new_mean < 2e-5,
            "cut cells {new_worst:e} {new_mean:e}, midpoint {old_worst:e} {old_mean:e}"
        );
        assert!(new_mean < old_mean, "cut cells {new_mean:e}, midpoint {old_mean:e}");
    }
}

/// A yaw of a fraction of a column has an exact answer, each texel the blend of two source
/// columns by the fraction (the column boundaries stay meridians, and the density does not
/// change along a row): the cut cells give it to f32 rounding away from the poles. (A brute force
/// on a grid of 512 cells a side is off by the same fraction of a cell in every texel: 4e-4 here.)
/// The pole rows' cells have corners on the pole, where the azimuth is undefined: their azimuth
/// planes are wrong, and they are split only until their error bound meets the tolerance (1e-9
/// of the map's magnitude, a large share of a pole texel's): off by up to 5e-4 there (measured
/// 4.9e-6, 1.7e-4 when their thin cells were split into four; `Rotate` takes the exact blend
/// instead, `rotation::yaw_columns`).
#[test]
fn a_fractional_yaw_blends_two_columns_exactly() {
    let (w, h) = (48, 24);
    let img = noise_map(w, h);
    // 7.5 degrees a column: a yaw of 2.04 columns, column x taking 0.96 of x + 2 and 0.04 of x + 3.
    let r = Rotation::from_yaw_pitch_roll(15.3, 0.0, 0.0);
    let out = rotated_latlong(&LatLongSource::new(&img), r.0.transpose(), 1e-9, 12);
    let (mut inside, mut poles) = (0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (img.pixel((x + 2) % w, y), img.pixel((x + 3) % w, y));
            for k in 0..3 {
                let want = 0.96 * a[k] as f64 + 0.04 * b[k] as f64;
                let e = (out.pixel(x, y)[k] as f64 - want).abs() / want;
                if y == 0 || y == h - 1 {
                    poles = poles.max(e);
                } else {
                    inside = inside.max(e);
                }
            }
        }
    }
    eprintln!("fractional yaw: rows 1 to H - 2 {inside:e}, pole rows {poles:e}");
    assert!(inside < 1e-6 && poles < 5e-4, "rows 1 to H - 2 {inside:e}, pole rows {poles:e}");
}

#[test]
fn keeps_the_integral_and_a_constant() {
    let img = noise_map(96, 48);
    let want = latlong_integral(&img);
    for r in [Rotation::from_yaw_pitch_roll(12.5, -30.0, 7.0), Rotation::from_yaw_pitch_roll(0.0, 90.0, 0.0)] {
        let got =
            latlong_integral(&rotated_latlong(&LatLongSource::new(&img), r.0.transpose(), ROTATION_TOLERANCE, 12));
        for k in 0..3 {
            assert!(((got[k] - want[k]) / want[k]).abs() < 1e-6, "{r:?}: {got:?} vs {want:?}");
        }
    }
    let one = Image::from_vec(64, 32, 3, vec![1.0; 64 * 32 * 3]);
    let r = Rotation::from_yaw_pitch_roll(10.0, 20.0, 30.0);
    let out = rotated_latlong(&LatLongSource::new(&one), r.0, ROTATION_TOLERANCE, 12);
    assert!(out.data.iter().all(|&v| (v - 1.0).abs() < 1e-6));
}

#[test]
fn a_plane_cuts_the_square_into_exact_shares() {
    // u >= 0.25: a quarter of the square; with density 1 + 2v the share of v >= 0 is 3/4.
    let quarter = SQUARE.clip(Line { a: -0.25, b: 1.0, c: 0.0 });
    assert!((quarter.weight([0.0; 2]) - 0.25).abs() < 1e-15);
    let top = SQUARE.clip(Line { a: 0.0, b: 0.0, c: 1.0 });
    assert!((top.weight([0.0, 2.0]) - 0.75).abs() < 1e-15);
    // A diagonal through the centre halves it; its clipped half has three vertices.
    let half = SQUARE.clip(Line { a: 0.0, b: 1.0, c: 1.0 });
    assert_eq!(half.n, 3);
    assert!((half.weight([0.0; 2]) - 0.5).abs() < 1e-15);
}
