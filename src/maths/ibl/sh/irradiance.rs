//! Ramamoorthi and Hanrahan's irradiance from SH coefficients: the clamped-cosine band factors
//! `A_l`, the irradiance of a normal, and the diffuse sphere it lights (the "Irradiance" section
//! of the [parent module](super)). The consumer of the basis and the projection.

use std::f64::consts::PI;

use rayon::prelude::*;

use super::basis::{eval_sh, eval_sh_into, sh_count, sh_lm};
use super::project::project_latlong;
use crate::maths::render::relight::SphereView;
use crate::values::{Image, ShFrame};

/// The clamped-cosine kernel's band factor `A_l` (Ramamoorthi and Hanrahan 2001, eqs. 8-9):
/// `pi`, `2 pi / 3`, 0 for odd `l > 1`, and for even `l`
/// `2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) * l! / (2^l ((l/2)!)^2)`. The last factor is
/// `C(l, l/2) / 2^l = prod_{k=1}^{l/2} (2k - 1) / (2k)`, computed as that product (no factorial).
pub fn lambert_coefficient(l: usize) -> f64 {
    match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l & 1 == 1 => 0.0,
        _ => {
            let half = l / 2;
            let ratio: f64 = (1..=half).map(|k| (2 * k - 1) as f64 / (2 * k) as f64).product();
            // (-1)^(l/2 - 1): +1 when l/2 is odd.
            let sign = if half & 1 == 1 { 1.0 } else { -1.0 };
            2.0 * PI * sign / (((l + 2) * (l - 1)) as f64) * ratio
        }
    }
}

/// Ramamoorthi and Hanrahan's irradiance `E(n) = sum_{l <= order} A_l sum_m L_lm Y_lm(n)` per
/// channel, from coefficients `coeffs` in `frame` ([`project`]; at least `sh_count(order)` of
/// them, else this panics). `n` is normalised; a zero or non-finite `n` gives NaN. Not clamped:
/// a truncated expansion can be negative.
pub fn irradiance_sh(coeffs: &[[f64; 3]], order: usize, frame: ShFrame, n: [f64; 3]) -> [f64; 3] {
    let count = sh_count(order);
    assert!(coeffs.len() >= count, "{} SH coefficients for order {order}, need {count}", coeffs.len());
    let y = eval_sh(frame, order, n);
    let mut e = [0.0f64; 3];
    for (i, (c, yv)) in coeffs.iter().zip(&y).enumerate() {
        let a = lambert_coefficient(sh_lm(i).0);
        for ch in 0..3 {
            e[ch] += a * c[ch] * yv;
        }
    }
    e
}

/// The diffuse sphere lit by the order-`order` irradiance map of `env`:
/// `Lo = (albedo / pi) E_SH(n)` on `view`'s disc (normals from [`SphereView::normal_at`]), 0
/// elsewhere; `size` x `size` RGB, pixel for pixel comparable with `ReferenceSphere`.
/// Rows in parallel; the map is projected once, in the `LatLong` frame (`E` does not depend on
/// the frame).
pub fn sh_sphere(env: &Image, view: &SphereView, albedo: [f64; 3], order: usize) -> Image {
    let size = view.size;
    let mut image = Image::new(size, size, 3);
    if size == 0 {
        return image;
    }
    let count = sh_count(order);
    let coeffs = project_latlong(env, order, 0.0);
    // Fold A_l and albedo / pi into the coefficients once.
    let k: Vec<[f64; 3]> = coeffs
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let a = lambert_coefficient(sh_lm(i).0);
            [0, 1, 2].map(|ch| a * albedo[ch] / PI * c[ch])
        })
        .collect();
    image.data.par_chunks_mut(size * 3).enumerate().for_each(|(py, row)| {
        let mut y = vec![0.0f64; count];
        for px in 0..size {
            let Some(n) = view.normal_at(px, py) else { continue };
            eval_sh_into(ShFrame::LatLong, order, n, &mut y);
            let mut e = [0.0f64; 3];
            for (kv, yv) in k.iter().zip(&y) {
                for ch in 0..3 {
                    e[ch] += kv[ch] * yv;
                }
            }
            for ch in 0..3 {
                row[px * 3 + ch] = e[ch] as f32;
            }
        }
    });
    image
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::ibl::sh::frames::gauss_legendre;
    use crate::maths::ibl::sh::test_support::{random_dir, smooth_sky};
    use crate::maths::ibl::sh::*;
    use crate::maths::render::reference::irradiance_exact;
    use crate::maths::render::reference::tests::{fibonacci, map};
    use crate::maths::sampling::sequences::SplitMix64;

    #[test]
    fn lambert_coefficients() {
        assert_eq!(lambert_coefficient(0), PI);
        assert!((lambert_coefficient(1) - 2.0 * PI / 3.0).abs() < 1e-15);
        assert!((lambert_coefficient(2) - PI / 4.0).abs() < 1e-15);
        assert_eq!(lambert_coefficient(3), 0.0);
        assert!((lambert_coefficient(4) + PI / 24.0).abs() < 1e-15);
        assert!((lambert_coefficient(6) - PI / 64.0).abs() < 1e-15);
        // Funk-Hecke: A_l = 2 pi int_0^1 P_l(t) t dt (Gauss-Legendre on [0, 1], exact here).
        let nodes = gauss_legendre(20);
        for l in 0..=12usize {
            let mut integral = 0.0;
            for &(x, w) in &nodes {
                let t = 0.5 * (x + 1.0);
                let (mut p0, mut p1) = (1.0f64, t);
                let p = if l == 0 {
                    1.0
                } else {
                    for k in 2..=l {
                        let p2 = ((2 * k - 1) as f64 * t * p1 - (k - 1) as f64 * p0) / k as f64;
                        p0 = p1;
                        p1 = p2;
                    }
                    p1
                };
                integral += 0.5 * w * p * t;
            }
            let want = 2.0 * PI * integral;
            assert!((lambert_coefficient(l) - want).abs() < 1e-13, "A_{l}: {} vs {want}", lambert_coefficient(l));
        }
    }

    /// Ramamoorthi and Hanrahan 2001, eq. 13, with c1..c5 = 0.429043, 0.511664, 0.743125,
    /// 0.886227, 0.247708.
    #[test]
    fn order_2_irradiance_matches_eq_13() {
        let mut rng = SplitMix64::new(3);
        let coeffs: Vec<[f64; 3]> = (0..9).map(|_| [rng.next_f64() - 0.5, rng.next_f64(), 1.0]).collect();
        let (c1, c2, c3, c4, c5) = (0.429043, 0.511664, 0.743125, 0.886227, 0.247708);
        for (frame, n) in ShFrame::ALL.iter().flat_map(|f| (0..100).map(move |_| *f)).map(|f| (f, random_dir(&mut rng)))
        {
            let [x, y, z] = frame.axes(n);
            let l = |i: usize| coeffs[i][0];
            let want = c1 * l(8) * (x * x - y * y) + c3 * l(6) * z * z + c4 * l(0) - c5 * l(6)
                + 2.0 * c1 * (l(4) * x * y + l(7) * x * z + l(5) * y * z)
                + 2.0 * c2 * (l(3) * x + l(1) * y + l(2) * z);
            let got = irradiance_sh(&coeffs, 2, frame, n)[0];
            assert!((got - want).abs() < 1e-5, "{frame:?}: {got} vs {want}");
        }
    }

    /// A map that is exactly band-limited to l <= 2 (made positive by a constant): order 2 is
    /// then exact, and order 4 adds nothing; both match the brute-force sum to the midpoint rule.
    #[test]
    fn band_limited_map_matches_irradiance_exact() {
        let c = [1.0, 0.2, -0.3, 0.25, 0.1, -0.15, 0.2, 0.05, -0.1];
        let env = map(256, 128, |d| {
            let y = eval_sh(ShFrame::LatLong, 2, d);
            let v: f64 = 3.0 * y[0] + c.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>();
            [v, 0.5 * v, 2.0 - v * 0.1]
        });
        assert!(env.data.iter().all(|&v| v > 0.0));
        let normals = fibonacci(500);
        let exact = irradiance_exact(&env, &normals);
        for (order, frame) in [2usize, 4].into_iter().flat_map(|o| ShFrame::ALL.map(|f| (o, f))) {
            let coeffs = project(&env, order, frame);
            let mut worst = 0.0f64;
            for (n, e) in normals.iter().zip(&exact) {
                let s = irradiance_sh(&coeffs, order, frame, *n);
                for ch in 0..3 {
                    worst = worst.max((s[ch] / e[ch] - 1.0).abs());
                }
            }
            eprintln!("band-limited map, order {order}, {frame:?}: worst relative difference to exact {worst:.2e}");
            assert!(worst < 1e-4, "order {order}, {frame:?}: {worst}");
        }
    }

    /// (worst, mean) relative error of the order-2 irradiance against the exact sum over 2000
    /// normals spread over the whole sphere (first channel).
    fn order2_errors(env: &Image) -> (f64, f64) {
        let normals = fibonacci(2000);
        let exact = irradiance_exact(env, &normals);
        let coeffs = project(env, 2, ShFrame::World);
        let mut worst = 0.0f64;
        let mut sum = 0.0f64;
        for (n, e) in normals.iter().zip(&exact) {
            let r = (irradiance_sh(&coeffs, 2, ShFrame::World, *n)[0] / e[0] - 1.0).abs();
            worst = worst.max(r);
            sum += r;
        }
        (worst, sum / normals.len() as f64)
    }

    #[test]
    fn order_2_on_smooth_maps_is_within_ramamoorthi_hanrahan_bounds() {
        let linear = crate::formats::builtin::builtin("linear").unwrap();
        let (worst, mean) = order2_errors(&linear);
        eprintln!("order 2, builtin linear: worst {:.3}%, mean {:.4}%", 100.0 * worst, 100.0 * mean);
        // Linear radiance is band-limited to l <= 1: only the midpoint rule remains.
        assert!(worst < 5e-4, "{worst}");

        let sky = smooth_sky(256, 128);
        let (worst, mean) = order2_errors(&sky);
        eprintln!("order 2, smooth sky without sun: worst {:.2}%, mean {:.2}%", 100.0 * worst, 100.0 * mean);
        assert!(worst < 0.09, "{worst}");
        assert!(mean < 0.015, "{mean}");
    }

    /// Not a bound: the error on a map with a small sun is large, as expected (R&H's bounds do
    /// not hold for a sun); it is reported so that it is seen.
    #[test]
    fn order_2_with_a_sun_reports_its_error() {
        let sky = crate::formats::builtin::builtin("sky").unwrap();
        let (worst, mean) = order2_errors(&sky);
        eprintln!(
            "order 2, builtin sky WITH its 2-degree sun: worst {:.1}%, mean {:.1}% (expected to be large)",
            100.0 * worst,
            100.0 * mean
        );
        assert!(worst.is_finite() && mean.is_finite());
        // A hard horizon without sun, for comparison: a + b sign(d_y) has only l = 0 and odd
        // bands, and A_l = 0 for odd l > 1, so order 2 is exact here (up to the midpoint rule).
        let hard = map(256, 128, |d| if d[1] > 0.0 { [0.8, 0.85, 0.9] } else { [0.14, 0.15, 0.08] });
        let (worst, mean) = order2_errors(&hard);
        eprintln!(
            "order 2, hard horizon (sky 0.8 / ground 0.14): worst {:.2}%, mean {:.2}%",
            100.0 * worst,
            100.0 * mean
        );
    }

    #[test]
    fn sh_sphere_matches_irradiance_sh_and_is_black_off_disc() {
        let env = smooth_sky(64, 32);
        let view = SphereView::new(24, [0.3, 0.5, 0.8]);
        let albedo = [0.8, 0.6, 0.4];
        let img = sh_sphere(&env, &view, albedo, 3);
        // The sphere is rendered in the LatLong frame, checked here in the World frame.
        let coeffs = project(&env, 3, ShFrame::World);
        for py in 0..24 {
            for px in 0..24 {
                let p = img.pixel(px, py);
                match view.normal_at(px, py) {
                    None => assert_eq!(p, &[0.0f32; 3][..]),
                    Some(n) => {
                        let e = irradiance_sh(&coeffs, 3, ShFrame::World, n);
                        for ch in 0..3 {
                            let want = albedo[ch] / PI * e[ch];
                            assert!((p[ch] as f64 - want).abs() <= 1e-6 * want.abs().max(1e-3), "{p:?} {want}");
                        }
                    }
                }
            }
        }
        // Order 0: the constant band only.
        let c0 = project(&env, 0, ShFrame::World);
        assert_eq!(c0.len(), 1);
        let e = irradiance_sh(&c0, 0, ShFrame::World, [0.0, 1.0, 0.0]);
        assert!((e[0] - PI * c0[0][0] * 0.5 / PI.sqrt()).abs() < 1e-12);
    }
}
