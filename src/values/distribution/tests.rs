//! Tests of [`Distribution2D`]: invariants, pdf integrals, sampling histograms, bad texels.

use super::*;

// Test-only: the generator and the chi-square test are maths'; `data` itself depends on
// `maths` only for the row kernels, a leaf (the lat-long geometry it needs is
// `geometry::latlong`).
use crate::maths::sampling::chi_square::chi_square_test;
use crate::maths::sampling::sequences::SplitMix64;
use std::f64::consts::PI;

/// A random map: values in [0, 10) with about a fifth of the texels zero, and row
/// `zero_row` (if any) all zero.
pub(super) fn random_map(w: usize, h: usize, seed: u64, zero_row: Option<usize>) -> Image {
    let mut rng = SplitMix64::new(seed);
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        for _ in 0..w {
            let v = if rng.next_f64() < 0.2 || Some(y) == zero_row { 0.0 } else { 10.0 * rng.next_f64() };
            data.push(v as f32);
        }
    }
    Image::from_vec(w, h, 1, data)
}

/// `sum_{x,y} pdf(x, y) dOmega_y`, which must be 1.
fn pdf_integral(d: &Distribution2D) -> f64 {
    let mut s = 0.0;
    for y in 0..d.height {
        let sa = texel_solid_angle(y, d.width, d.height);
        for x in 0..d.width {
            s += d.pdf(x, y) * sa;
        }
    }
    s
}

fn check_invariants(d: &Distribution2D) {
    assert_eq!(d.weights().len(), d.width * d.height);
    assert_eq!(d.conditional_cdf.len(), d.height * (d.width + 1));
    assert_eq!(d.row_sums.len(), d.height);
    assert_eq!(d.marginal_cdf.len(), d.height + 1);
    assert_eq!(d.marginal_cdf[0], 0.0);
    assert_eq!(d.marginal_cdf[d.height], 1.0);
    assert!(d.marginal_cdf.windows(2).all(|p| p[0] <= p[1]));
    for y in 0..d.height {
        let row = d.conditional_row(y);
        assert_eq!(row[0], 0.0);
        assert_eq!(row[d.width], 1.0);
        assert!(row.windows(2).all(|p| p[0] <= p[1]));
    }
    for y in 0..d.height {
        for x in 0..d.width {
            let p = d.pdf(x, y);
            assert!(p.is_finite() && p >= 0.0);
        }
    }
}

fn build(img: &Image, sin_theta: bool) -> Distribution2D {
    let d = Distribution2D::build(img, sin_theta, false).unwrap();
    check_invariants(&d);
    d
}

#[test]
fn pdf_integrates_to_one() {
    let mut maps = vec![
        random_map(16, 8, 1, None),
        random_map(33, 17, 2, Some(5)),
        random_map(64, 32, 3, Some(0)),
        Image::from_vec(8, 4, 1, vec![2.5; 32]),
        Image::new(12, 6, 1),
        Image::from_vec(1, 1, 1, vec![3.0]),
        Image::from_vec(1, 1, 1, vec![0.0]),
        random_map(1, 7, 4, None),
        random_map(7, 1, 5, None),
        Image::new(1, 7, 1),
        Image::new(7, 1, 1),
    ];
    let mut hot = Image::new(16, 8, 1);
    hot.data[5 * 16 + 3] = 1000.0;
    maps.push(hot);
    for img in &maps {
        for sin_theta in [true, false] {
            let d = build(img, sin_theta);
            let s = pdf_integral(&d);
            assert!((s - 1.0).abs() < 1e-12, "{}x{} sin {sin_theta}: {s}", img.width, img.height);
            let p: f64 = (0..d.height)
                .flat_map(|y| (0..d.width).map(move |x| (x, y)))
                .map(|(x, y)| d.texel_probability(x, y))
                .sum();
            assert!((p - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn all_black_map_falls_back_to_uniform_solid_angle() {
    let d = build(&Image::new(16, 8, 1), true);
    assert!(!d.carries_light);
    assert_eq!(d.total, 0.0);
    assert_eq!(d.luminance_integral, 0.0);
    let p0 = d.pdf(0, 0);
    for y in 0..8 {
        for x in 0..16 {
            assert!((d.pdf(x, y) - p0).abs() < 1e-12 * p0);
        }
    }
    assert!((p0 - 1.0 / (4.0 * PI)).abs() < 1e-2 / (4.0 * PI));
    let (x, y, pdf) = d.sample(0.3, 0.9);
    assert!(x < 16 && y < 8 && pdf > 0.0);
}

#[test]
fn hot_texel_is_always_sampled() {
    let mut img = Image::new(16, 8, 1);
    img.data[5 * 16 + 3] = 1e6;
    let d = build(&img, true);
    let mut rng = SplitMix64::new(3);
    let mut us = vec![(0.0, 0.0), (1.0, 1.0), (ONE_MINUS_EPSILON, ONE_MINUS_EPSILON), (0.0, 1.0), (1.0, 0.0)];
    for _ in 0..1000 {
        us.push((rng.next_f64(), rng.next_f64()));
    }
    let expect = d.pdf(3, 5);
    assert!(expect > 0.0);
    for (u1, u2) in us {
        assert_eq!(d.sample(u1, u2), (3, 5, expect), "u = ({u1}, {u2})");
    }
    // pdf * solid angle = 1 for the single texel.
    assert!((expect * texel_solid_angle(5, 16, 8) - 1.0).abs() < 1e-12);
}

#[test]
fn edge_u_values_skip_zero_rows_and_columns() {
    // Zero first and last rows, zero first and last columns.
    let (w, h) = (6usize, 5usize);
    let mut img = Image::new(w, h, 1);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            img.data[y * w + x] = 1.0 + (x * y) as f32;
        }
    }
    for sin_theta in [true, false] {
        let d = build(&img, sin_theta);
        for &u1 in &[0.0, f64::MIN_POSITIVE, ONE_MINUS_EPSILON, 1.0, 1.5, -0.5, f64::NAN] {
            for &u2 in &[0.0, ONE_MINUS_EPSILON, 1.0] {
                let (x, y, pdf) = d.sample(u1, u2);
                assert!((1..w - 1).contains(&x) && (1..h - 1).contains(&y), "u ({u1}, {u2}) -> ({x}, {y})");
                assert!(pdf.is_finite() && pdf > 0.0);
                assert_eq!(pdf, d.pdf(x, y));
            }
        }
        assert_eq!(d.sample(0.0, 0.0).0, 1);
        assert_eq!(d.sample(0.0, 0.0).1, 1);
        assert_eq!(d.sample(1.0, 1.0).0, w - 2);
        assert_eq!(d.sample(1.0, 1.0).1, h - 2);
    }
}

#[test]
fn samples_never_land_on_zero_texels() {
    let img = random_map(32, 16, 9, Some(7));
    let d = build(&img, true);
    let mut rng = SplitMix64::new(10);
    for _ in 0..20_000 {
        let (x, y, pdf) = d.sample(rng.next_f64(), rng.next_f64());
        assert!(img.data[y * 32 + x] > 0.0 && d.weight(x, y) > 0.0 && pdf > 0.0);
        assert_ne!(y, 7);
    }
}

#[test]
fn chi_square_against_texel_probability() {
    let (w, h) = (8usize, 6usize);
    let img = random_map(w, h, 21, Some(2));
    for sin_theta in [true, false] {
        let d = build(&img, sin_theta);
        let n = 100_000usize;
        let mut obs = vec![0.0; w * h];
        let mut rng = SplitMix64::new(77);
        for _ in 0..n {
            let (x, y, _) = d.sample(rng.next_f64(), rng.next_f64());
            obs[y * w + x] += 1.0;
        }
        let exp: Vec<f64> = (0..w * h).map(|i| n as f64 * d.texel_probability(i % w, i / w)).collect();
        let r = chi_square_test(&obs, &exp, 5.0);
        assert_eq!(r.impossible_cells, 0);
        assert!(r.p_value > 1e-4, "sin {sin_theta}: {r:?}");
    }
}

#[test]
fn pdf_matches_pbrt_v3_formula() {
    let (w, h) = (20usize, 10usize);
    let img = random_map(w, h, 31, None);
    let d = build(&img, true);
    for y in 0..h {
        for x in 0..w {
            let lum = img.data[y * w + x] as f64;
            let expect = lum * (w * h) as f64 / (2.0 * PI * PI * d.total);
            let got = d.pdf(x, y);
            assert!((got - expect).abs() <= 1e-12 * expect.max(1e-300), "({x}, {y}): {got} vs {expect}");
        }
    }
}

#[test]
fn constant_map_is_uniform_over_the_sphere() {
    let (w, h) = (64usize, 32usize);
    let d = build(&Image::from_vec(w, h, 1, vec![1.0; w * h]), true);
    let target = 1.0 / (4.0 * PI);
    for y in 0..h {
        for x in [0, w / 2, w - 1] {
            let p = d.pdf(x, y);
            // Midpoint rule: sum_y sin(theta_y) (pi / H) = 2 (1 + O(1/H^2)).
            assert!((p - target).abs() < 1e-3 * target, "row {y}: {p}");
        }
    }
    // The luminance integral of a constant 1 is the sphere's area, 4 pi (midpoint rule).
    assert!((d.luminance_integral - 4.0 * PI).abs() < 1e-3 * 4.0 * PI);
}

#[test]
fn bad_texels_error_or_are_sanitised() {
    let (w, h) = (4usize, 5usize);
    let mut img = Image::from_vec(w, h, 1, vec![1.0; w * h]);
    img.data[3 * w] = -1.0; // (0, 3)
    img.data[w + 2] = f32::NAN; // (2, 1): first in row-major order
    img.data[4 * w + 1] = f32::INFINITY; // (1, 4)
    img.data[2 * w + 3] = f32::NEG_INFINITY; // (3, 2)
    match Distribution2D::build(&img, true, false) {
        Err(DistributionError::BadTexel { x, y, value }) => {
            assert_eq!((x, y), (2, 1));
            assert!(value.is_nan());
        }
        other => panic!("expected BadTexel, got {other:?}"),
    }
    let msg = Distribution2D::build(&img, true, false).unwrap_err().to_string();
    assert!(msg.contains("sanitize: true"), "{msg}");

    let d = Distribution2D::build(&img, true, true).unwrap();
    check_invariants(&d);
    assert!(d.carries_light);
    assert_eq!(d.texel_probability(2, 1), 0.0);
    assert_eq!(d.texel_probability(0, 3), 0.0);
    assert_eq!(d.texel_probability(3, 2), 0.0);
    let expect = f32::MAX as f64 * theta_of_row(4, h).sin();
    assert!((d.weight(1, 4) - expect).abs() <= 1e-15 * expect);
    assert!(d.texel_probability(1, 4) > 0.999_999);
    assert!((pdf_integral(&d) - 1.0).abs() < 1e-12);
    assert!(d.luminance_integral.is_finite());

    // Only an infinite texel: still an error without sanitising.
    let mut img = Image::from_vec(2, 2, 1, vec![1.0; 4]);
    img.data[3] = f32::INFINITY;
    assert!(matches!(Distribution2D::build(&img, false, false), Err(DistributionError::BadTexel { x: 1, y: 1, .. })));
    // -0.0 is fine and weighs nothing.
    let img = Image::from_vec(2, 1, 1, vec![-0.0, 1.0]);
    let d = build(&img, true);
    assert_eq!(d.texel_probability(0, 0), 0.0);
    assert_eq!(d.sample(0.0, 0.0).0, 1);
}

#[test]
fn huge_dynamic_range() {
    let (w, h) = (16usize, 8usize);
    let mut img = random_map(w, h, 41, None);
    img.data[3 * w + 5] = 1e30;
    img.data[6 * w + 1] = f32::MAX;
    img.data[0] = 1e-30;
    for sin_theta in [true, false] {
        let d = build(&img, sin_theta);
        assert!(d.total.is_finite() && d.carries_light);
        assert!((pdf_integral(&d) - 1.0).abs() < 1e-12);
        let (x, y, pdf) = d.sample(0.5, 0.5);
        assert!(pdf.is_finite() && pdf > 0.0 && img.data[y * w + x] > 0.0);
        // A tiny texel keeps a tiny but positive, finite pdf.
        assert!(d.pdf(0, 0) > 0.0);
    }
}

#[test]
fn rejects_wrong_shapes() {
    assert!(matches!(Distribution2D::build(&Image::new(4, 2, 3), true, false), Err(DistributionError::Invalid(_))));
    assert!(matches!(Distribution2D::build(&Image::new(0, 2, 1), true, false), Err(DistributionError::Invalid(_))));
    assert!(matches!(Distribution2D::build(&Image::new(4, 0, 1), true, false), Err(DistributionError::Invalid(_))));
}

#[test]
fn thin_maps_sample_correctly() {
    for (w, h) in [(1usize, 7usize), (7, 1), (1, 1)] {
        let img = random_map(w, h, 51, None);
        let d = build(&img, true);
        for &(u1, u2) in &[(0.0, 0.0), (1.0, 1.0), (0.5, 0.5), (ONE_MINUS_EPSILON, 0.0)] {
            let (x, y, pdf) = d.sample(u1, u2);
            assert!(x < w && y < h && pdf.is_finite());
            if d.carries_light {
                assert!(pdf > 0.0);
            }
        }
    }
}

#[test]
fn parallel_build_is_deterministic() {
    let img = random_map(50, 25, 61, Some(3));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let one = pool.install(|| Distribution2D::build(&img, true, false).unwrap());
    let many = Distribution2D::build(&img, true, false).unwrap();
    assert_eq!(one, many);
    assert!(many.approx_bytes() >= 8 * (25 * 51 + 25 + 26));
    // pdf_direction agrees with the texel lookup at texel centres.
    for (x, y) in [(0usize, 0usize), (10, 7), (49, 24)] {
        let dir = crate::geometry::latlong::texel_direction(x, y, 50, 25);
        assert_eq!(many.pdf_direction(dir), many.pdf(x, y));
    }
}

#[test]
fn weights_match_the_luminance_to_rounding() {
    // Large enough (4.8 MiB of CDF) for `advise_huge_pages` to act.
    let (w, h) = (1000usize, 600usize);
    let img = random_map(w, h, 71, Some(10));
    for sin_theta in [true, false] {
        let d = build(&img, sin_theta);
        let weights = d.weights();
        let mut total = 0.0;
        for y in 0..h {
            let s = if sin_theta { theta_of_row(y, h).sin() } else { 1.0 };
            let row_sum: f64 = img.row(y).iter().map(|&v| v as f64 * s).sum();
            assert!((d.row_sums[y] - row_sum).abs() <= 1e-13 * row_sum, "row {y}");
            total += row_sum;
            for x in 0..w {
                let expect = img.data[y * w + x] as f64 * s;
                let got = d.weight(x, y);
                assert_eq!(got, weights[y * w + x]);
                // The interval's ends carry an absolute error of a few 2^-53 of the row sum.
                assert!((got - expect).abs() <= 1e-9 * expect + 8.0 * f64::EPSILON * row_sum, "({x}, {y})");
                assert_eq!(got > 0.0, expect > 0.0, "({x}, {y})");
            }
        }
        assert!((d.total - total).abs() <= 1e-12 * total);
    }
}

#[test]
fn a_texel_lost_in_the_running_sum_has_pdf_zero_and_is_never_sampled() {
    // Row 0: a 1e-3 texel after a 1e30 one disappears from the f64 running sum; before it, it
    // keeps its (tiny) probability.
    let img = Image::from_vec(2, 2, 1, vec![1e30, 1e-3, 1e-3, 1e30]);
    let d = build(&img, true);
    assert_eq!(d.texel_probability(1, 0), 0.0);
    assert_eq!(d.pdf(1, 0), 0.0);
    assert!(d.pdf(0, 1) > 0.0 && d.weight(0, 1) > 0.0);
    let mut rng = SplitMix64::new(8);
    for _ in 0..10_000 {
        let (x, y, pdf) = d.sample(rng.next_f64(), rng.next_f64());
        assert!((x, y) != (1, 0) && pdf > 0.0);
    }
}
