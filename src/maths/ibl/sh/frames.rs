//! The change of SH frame: per-band matrices from the `LatLong` frame to `World` or `Paper` by
//! exact (Gauss-Legendre) quadrature (the "Frames" and "Projection" sections of the [parent
//! module](super)). Its own file because it is a separate step after projection, with its own
//! quadrature.

use std::f64::consts::PI;

use rayon::prelude::*;

use super::basis::{eval_basis, sh_count};
use crate::values::ShFrame;

/// Gauss-Legendre nodes and weights on [-1, 1], exact for polynomials of degree `2n - 1`
/// (Newton on `P_n` from the Chebyshev guess; Press et al., *Numerical Recipes* 3rd ed.,
/// section 4.6, `gauleg`).
pub(super) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0f64, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// The change of frame from `LatLong` to `frame`, one matrix per band `l <= order`
/// ((2l + 1)^2 entries, row-major, rows and columns by `m = -l..=l`):
/// `T_l[m][m'] = int Y_lm(frame axes of d) Y_lm'(LatLong axes of d) dd`, so that
/// `L_lm(frame) = sum_m' T_l[m][m'] L_lm'(LatLong)`. Computed by quadrature that is exact for
/// these degree-`2l` polynomials: `order + 1` Gauss-Legendre nodes in `cos t` times
/// `2 order + 1` equally spaced azimuths; entries within 1e-13 of 0, 1 or -1 are set to it.
/// Nodes in parallel, added in node order (deterministic).
pub fn frame_matrices(frame: ShFrame, order: usize) -> Vec<Vec<f64>> {
    let count = sh_count(order);
    let blocks = |l: usize| (2 * l + 1) * (2 * l + 1);
    if frame == ShFrame::LatLong {
        return (0..=order)
            .map(|l| {
                let n = 2 * l + 1;
                (0..blocks(l)).map(|k| if k / n == k % n { 1.0 } else { 0.0 }).collect()
            })
            .collect();
    }
    let n_phi = 2 * order + 1;
    let partial: Vec<Vec<Vec<f64>>> = gauss_legendre(order + 1)
        .into_par_iter()
        .map(|(z, wz)| {
            let s = (1.0 - z * z).max(0.0).sqrt();
            let w = wz * 2.0 * PI / n_phi as f64;
            let mut t: Vec<Vec<f64>> = (0..=order).map(|l| vec![0.0; blocks(l)]).collect();
            let (mut yf, mut yl) = (vec![0.0; count], vec![0.0; count]);
            for k in 0..n_phi {
                let (sp, cp) = (2.0 * PI * (k as f64 + 0.5) / n_phi as f64).sin_cos();
                // LatLong axes p = (d_z, -d_x, d_y), so d = (-p_y, p_z, p_x).
                let p = [s * cp, s * sp, z];
                eval_basis(order, p, &mut yl);
                eval_basis(order, frame.axes([-p[1], p[2], p[0]]), &mut yf);
                for (l, tl) in t.iter_mut().enumerate() {
                    let (base, n) = (l * l, 2 * l + 1);
                    for a in 0..n {
                        let fa = w * yf[base + a];
                        for b in 0..n {
                            tl[a * n + b] += fa * yl[base + b];
                        }
                    }
                }
            }
            t
        })
        .collect();
    let mut total: Vec<Vec<f64>> = (0..=order).map(|l| vec![0.0; blocks(l)]).collect();
    for t in partial {
        for (acc, tl) in total.iter_mut().zip(t) {
            for (a, v) in acc.iter_mut().zip(tl) {
                *a += v;
            }
        }
    }
    for v in total.iter_mut().flatten() {
        for exact in [0.0, 1.0, -1.0] {
            if (*v - exact).abs() < 1e-13 {
                *v = exact;
            }
        }
    }
    total
}

/// Coefficients `coeffs` (`sh_count(order)` of them, in the `LatLong` frame) in `frame`.
pub fn from_latlong(coeffs: &[[f64; 3]], order: usize, frame: ShFrame) -> Vec<[f64; 3]> {
    if frame == ShFrame::LatLong {
        return coeffs.to_vec();
    }
    let mut out = vec![[0.0f64; 3]; sh_count(order)];
    for (l, t) in frame_matrices(frame, order).iter().enumerate() {
        let (base, n) = (l * l, 2 * l + 1);
        for a in 0..n {
            for ch in 0..3 {
                out[base + a][ch] = (0..n).map(|b| t[a * n + b] * coeffs[base + b][ch]).sum();
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;
    use crate::maths::ibl::sh::test_support::{close, lumpy};
    use crate::maths::ibl::sh::*;
    use crate::maths::render::reference::tests::fibonacci;

    /// The change-of-frame matrices are orthogonal, identity at l = 0 and exact signed
    /// permutations at l = 1, and no entry lies near the snapping threshold (up to order 32).
    #[test]
    fn frame_matrices_are_orthogonal() {
        for frame in ShFrame::ALL {
            let t = frame_matrices(frame, 32);
            assert_eq!(t[0], vec![1.0]);
            assert!(t[1].iter().all(|v| [0.0, 1.0, -1.0].contains(v)), "{frame:?} {:?}", t[1]);
            let mut smallest = f64::INFINITY;
            for (l, tl) in t.iter().enumerate() {
                let n = 2 * l + 1;
                for a in 0..n {
                    for b in 0..n {
                        let dot: f64 = (0..n).map(|k| tl[a * n + k] * tl[b * n + k]).sum();
                        let want = if a == b { 1.0 } else { 0.0 };
                        assert!((dot - want).abs() < 1e-12, "{frame:?} l = {l}: ({a}, {b}) {dot}");
                    }
                }
                smallest = tl.iter().map(|v| v.abs()).filter(|&v| v > 0.0).fold(smallest, f64::min);
            }
            eprintln!("{frame:?}: smallest non-zero entry up to l = 32: {smallest:.2e}");
            assert!(smallest > 1e-11, "{frame:?}: an entry of {smallest:e} is close to the 1e-13 snapping threshold");
        }
    }

    /// Projecting in the LatLong frame and changing frame gives the midpoint sum taken directly
    /// in each frame's axes.
    #[test]
    fn projection_in_a_frame_equals_the_direct_midpoint_sum() {
        let order = 5;
        let env = lumpy(96, 48);
        for frame in ShFrame::ALL {
            let got = project(&env, order, frame);
            let mut want = vec![[0.0f64; 3]; sh_count(order)];
            for y in 0..env.height {
                let d_omega = latlong::texel_solid_angle(y, env.width, env.height);
                for x in 0..env.width {
                    let d = latlong::texel_direction(x, y, env.width, env.height);
                    let basis = eval_sh(frame, order, d);
                    let l = env.rgb(x, y);
                    for (w, b) in want.iter_mut().zip(&basis) {
                        for ch in 0..3 {
                            w[ch] += l[ch] as f64 * b * d_omega;
                        }
                    }
                }
            }
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(close(*g, *w, 1e-12 * 20.0), "{frame:?} {:?}: {g:?} vs {w:?}", sh_lm(i));
            }
        }
    }

    /// (c) The same map in the three frames: World and Paper are mirror images
    /// (`(-1)^(l+m)`); World from LatLong is the fixed axis map `(X, Y, Z) = (-y, z, x)` of
    /// LatLong's `(x, y, z)`: l = 0 equal, l = 1 a signed permutation, l = 2 as derived by hand.
    #[test]
    fn world_paper_and_latlong_coefficients_relate_by_the_fixed_axis_map() {
        let order = 4;
        let env = lumpy(128, 64);
        let [w, p, ll] = ShFrame::ALL.map(|f| project(&env, order, f));
        let c = |v: &[[f64; 3]], l: usize, m: isize| v[sh_index(l, m)];
        let neg = |v: [f64; 3]| v.map(|x| -x);
        assert_eq!(w[0], ll[0]);
        assert_eq!(p[0], ll[0]);
        for (i, (wi, pi)) in w.iter().zip(&p).enumerate() {
            let (l, m) = sh_lm(i);
            let sign = if (l as isize + m) % 2 == 0 { 1.0 } else { -1.0 };
            assert!(close(*pi, wi.map(|x| sign * x), 1e-12), "Paper {:?}: {pi:?} vs {wi:?}", (l, m));
        }
        // Band 1: Y_1-1 = c y, Y_10 = c z, Y_11 = c x; World (x, y, z) = (-y', z', x') of
        // LatLong's (x', y', z').
        assert_eq!(c(&w, 1, -1), c(&ll, 1, 0));
        assert_eq!(c(&w, 1, 0), c(&ll, 1, 1));
        assert_eq!(c(&w, 1, 1), neg(c(&ll, 1, -1)));
        // Band 2: xy = -y'z', yz = z'x', 3z^2 - 1 = 3x'^2 - 1, xz = -y'x', x^2 - y^2 = y'^2 - z'^2.
        let (h, r3) = (0.5, 3f64.sqrt() / 2.0);
        let mix = |a: f64, u: [f64; 3], b: f64, v: [f64; 3]| [0, 1, 2].map(|ch| a * u[ch] + b * v[ch]);
        let tol = 1e-12 * 10.0;
        assert!(close(c(&w, 2, -2), neg(c(&ll, 2, -1)), tol));
        assert!(close(c(&w, 2, -1), c(&ll, 2, 1), tol));
        assert!(close(c(&w, 2, 0), mix(-h, c(&ll, 2, 0), r3, c(&ll, 2, 2)), tol));
        assert!(close(c(&w, 2, 1), neg(c(&ll, 2, -2)), tol));
        assert!(close(c(&w, 2, 2), mix(-r3, c(&ll, 2, 0), -h, c(&ll, 2, 2)), tol));
        // The frame does not change the energy per band, nor the irradiance.
        for l in 0..=order {
            let energy = |v: &[[f64; 3]]| (0..2 * l + 1).map(|k| v[l * l + k][0].powi(2)).sum::<f64>();
            assert!((energy(&w) - energy(&ll)).abs() < 1e-12 * energy(&ll).max(1.0), "band {l}");
        }
        for n in fibonacci(50) {
            let e = irradiance_sh(&ll, order, ShFrame::LatLong, n);
            assert!(close(irradiance_sh(&w, order, ShFrame::World, n), e, 1e-12 * 50.0));
            assert!(close(irradiance_sh(&p, order, ShFrame::Paper, n), e, 1e-12 * 50.0));
        }
    }

    /// (d) The built-in `linear` map, `L(d) = a + b.d`: `L_00 = a int Y_00 = 2 sqrt(pi) a`, and in
    /// the World frame `L_1,-1 = int (b.d) c d_y dd = c b_y int d_y^2 dd = c (4 pi / 3) b_y =
    /// sqrt(4 pi / 3) b_y` with `c = sqrt(3 / (4 pi))`; likewise `L_10` with `b_z` and `L_11` with
    /// `b_x`: the order (y, z, x). Band 2 is 0 (a linear function has no l = 2 part). Paper
    /// negates `L_10`.
    #[test]
    fn linear_map_has_the_closed_form_world_coefficients() {
        use crate::formats::builtin::{builtin, LINEAR_A, LINEAR_B};
        let env = builtin("linear").unwrap();
        let k = (4.0 * PI / 3.0).sqrt();
        let [bx, by, bz] = LINEAR_B;
        let w = project(&env, 2, ShFrame::World);
        let want = [2.0 * PI.sqrt() * LINEAR_A, k * by, k * bz, k * bx, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut worst = 0.0f64;
        for (g, w) in w.iter().zip(&want) {
            for v in g {
                worst = worst.max((v - w).abs());
            }
        }
        eprintln!("builtin linear, World frame: worst coefficient error {worst:.1e} (midpoint rule, 128x64)");
        assert!(worst < 1e-3, "{w:?} vs {want:?}");
        let p = project(&env, 2, ShFrame::Paper);
        assert!((p[2][0] + k * bz).abs() < 1e-3 && (p[1][0] - k * by).abs() < 1e-3 && (p[3][0] - k * bx).abs() < 1e-3);
    }
}
