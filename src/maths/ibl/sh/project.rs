//! Projection of a lat-long map onto the SH basis: one Fourier sum per row times the row's
//! normalised Legendre values, rows in parallel and added in row order (the "Projection" section
//! of the [parent module](super)), optionally turned about +Y without resampling the map.

use std::f64::consts::SQRT_2;

use rayon::prelude::*;

use super::basis::{legendre_q, sh_count};
use super::frames::from_latlong;
use crate::geometry::latlong;
use crate::values::{Image, ShFrame};

/// The coefficients `L_lm = sum_texels L Y_lm(d) dOmega` of `env` up to `order`, per channel,
/// in `frame`'s axes (index [`sh_index`]; a one-channel map is read as grey). Exact sum over the
/// texels (midpoint solid angle), f64, rows in parallel, deterministic (see the module
/// documentation). An empty map gives zeros; non-finite texels give non-finite coefficients.
pub fn project(env: &Image, order: usize, frame: ShFrame) -> Vec<[f64; 3]> {
    project_turned(env, order, frame, 0.0)
}

/// [`project`] of `env` turned by `yaw` degrees about +Y as `Rotate(yaw)` turns it (`maths::resample::rotation`),
/// without turning it: `L_lm = sum_texels L(d) Y_lm(R_y(yaw) d) dOmega`. A yaw about +Y is a shift
/// of the lat-long azimuth, so each texel's basis is evaluated at `phi - yaw` (exact for any angle;
/// for a whole-column yaw it equals the projection of the rolled map to summation order, tested).
pub fn project_turned(env: &Image, order: usize, frame: ShFrame, yaw: f64) -> Vec<[f64; 3]> {
    from_latlong(&project_latlong(env, order, -yaw.to_radians()), order, frame)
}

/// [`project`] in the `LatLong` frame, each column's azimuth shifted by `phi_shift` (radians): one
/// Fourier sum per row.
pub(super) fn project_latlong(env: &Image, order: usize, phi_shift: f64) -> Vec<[f64; 3]> {
    let count = sh_count(order);
    let (w, h) = (env.width, env.height);
    if w == 0 || h == 0 {
        return vec![[0.0; 3]; count];
    }
    // cos(m phi_x), sin(m phi_x) for every column and 0 <= m <= order.
    let trig: Vec<(f64, f64)> = (0..w)
        .flat_map(|x| {
            let phi = latlong::phi_of_column(x, w) + phi_shift;
            (0..=order).map(move |m| {
                let (s, c) = (m as f64 * phi).sin_cos();
                (c, s)
            })
        })
        .collect();
    let rows: Vec<Vec<[f64; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            // Fourier sums of the row: f[m][ch] = sum_x L cos(m phi), g[m][ch] = sum_x L sin(m phi).
            let mut f = vec![[0.0f64; 3]; order + 1];
            let mut g = vec![[0.0f64; 3]; order + 1];
            for x in 0..w {
                let l = env.rgb(x, y);
                let t = &trig[x * (order + 1)..(x + 1) * (order + 1)];
                for m in 0..=order {
                    for ch in 0..3 {
                        let v = l[ch] as f64;
                        f[m][ch] += v * t[m].0;
                        g[m][ch] += v * t[m].1;
                    }
                }
            }
            let theta = latlong::theta_of_row(y, h);
            let (st, ct) = theta.sin_cos();
            let d_omega = latlong::texel_solid_angle(y, w, h);
            let mut q = vec![0.0f64; count];
            legendre_q(order, ct, &mut q);
            let mut out = vec![[0.0f64; 3]; count];
            let mut s_m = 1.0f64; // sin(theta)^m
            for m in 0..=order {
                if m > 0 {
                    s_m *= st;
                }
                for l in m..=order {
                    let base = l * (l + 1);
                    let pbar = q[base + m] * s_m * d_omega;
                    for ch in 0..3 {
                        if m == 0 {
                            out[base][ch] = pbar * f[0][ch];
                        } else {
                            out[base + m][ch] = SQRT_2 * pbar * f[m][ch];
                            out[base - m][ch] = SQRT_2 * pbar * g[m][ch];
                        }
                    }
                }
            }
            out
        })
        .collect();
    let mut total = vec![[0.0f64; 3]; count];
    for row in rows {
        for (t, r) in total.iter_mut().zip(row) {
            for ch in 0..3 {
                t[ch] += r[ch];
            }
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::ibl::sh::test_support::{close, lumpy, smooth_sky};
    use crate::maths::ibl::sh::*;
    use crate::maths::render::reference::tests::map;
    use std::f64::consts::PI;

    /// A yaw is a shift of the azimuth: turning the coefficients equals turning the map. For a
    /// whole-column yaw the rolled map's projection agrees to summation order; for any yaw the
    /// l = 1 band (proportional to `sum L d dOmega`, (y, z, x) in `World`) turns with R_y(yaw), and
    /// each band's energy `sum_m L_lm^2` is unchanged.
    #[test]
    fn a_turned_projection_is_the_projection_of_the_turned_map() {
        use crate::geometry::rotation::Rotation;
        use crate::maths::resample::rotation::rotate_latlong;
        let env = map(64, 32, |d| [1.0 + d[0] + 0.5 * d[1] * d[2], (3.0 * d[2]).exp(), 2.0 + d[0] * d[0] - d[1]]);
        for yaw in [90.0, -90.0, 180.0, 33.75] {
            let turned = project_turned(&env, 4, ShFrame::World, yaw);
            let r = Rotation::from_yaw_pitch_roll(yaw, 0.0, 0.0);
            if r.whole_column_shift(env.width).is_some() {
                let rolled = project(&rotate_latlong(&env, r), 4, ShFrame::World);
                for (a, b) in turned.iter().zip(&rolled) {
                    for ch in 0..3 {
                        assert!((a[ch] - b[ch]).abs() < 1e-9 * (1.0 + b[ch].abs()), "yaw {yaw}: {a:?} vs {b:?}");
                    }
                }
            }
            let plain = project(&env, 4, ShFrame::World);
            for ch in 0..3 {
                let v = |c: &[[f64; 3]]| glam::DVec3::new(c[3][ch], c[1][ch], c[2][ch]);
                let want = r.0 * v(&plain);
                assert!((v(&turned) - want).length() < 1e-9 * (1.0 + want.length()), "yaw {yaw}: l = 1 band");
                for l in 0..=4usize {
                    let band = |c: &[[f64; 3]]| {
                        (-(l as isize)..=l as isize).map(|m| c[sh_index(l, m)][ch].powi(2)).sum::<f64>()
                    };
                    assert!((band(&turned) - band(&plain)).abs() < 1e-9 * (1.0 + band(&plain)), "yaw {yaw}: band {l}");
                }
            }
        }
    }

    #[test]
    fn projection_of_a_harmonic_is_a_unit_vector() {
        // Midpoint quadrature on a 256 x 128 map: exact in phi, O((pi/H)^2 l^2) in theta.
        let order = 8;
        let mut worst = 0.0f64;
        for i in [0usize, 2, 3, 6, 8, 12, 20, 40, 80] {
            let env = map(256, 128, |d| {
                let v = eval_sh(ShFrame::LatLong, order, d)[i];
                [v, -v, 2.0 * v]
            });
            let c = project(&env, order, ShFrame::LatLong);
            for (j, cj) in c.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((cj[0] - want).abs());
                assert!((cj[1] + cj[0]).abs() < 1e-6 && (cj[2] - 2.0 * cj[0]).abs() < 1e-6);
            }
        }
        eprintln!("projection of Y_lm (l <= 8) on 256x128: worst coefficient error {worst:.2e}");
        assert!(worst < 1e-3, "{worst}");
    }

    #[test]
    fn projection_is_independent_of_thread_count() {
        let env = smooth_sky(128, 64);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        for frame in ShFrame::ALL {
            let one = pool.install(|| project(&env, 6, frame));
            assert_eq!(one, project(&env, 6, frame));
        }
    }

    /// The map with its columns shifted by +W/4: `new(x) = old(x - W/4)`, so that
    /// `new(phi) = old(phi - pi/2)`. With `d = (-sin t sin p, cos t, sin t cos p)` the content at
    /// `d` moves to `R d = (-d_z, d_y, d_x)`: +X goes to +Z, +Z to -X (a rotation of -90 degrees
    /// about +Y, right-handed; clockwise seen from above).
    fn rotated_quarter(env: &Image) -> Image {
        assert_eq!(env.width % 4, 0);
        let mut out = env.clone();
        for y in 0..env.height {
            for x in 0..env.width {
                let src = (x + env.width - env.width / 4) % env.width;
                out.pixel_mut(x, y).copy_from_slice(env.pixel(src, y));
            }
        }
        out
    }

    /// (b) Rotating the map about +Y (columns shifted by +W/4, phi + pi/2; see
    /// [`rotated_quarter`]) transforms the coefficients as the frame's axes say. With
    /// `R d = (-d_z, d_y, d_x)`, `L'_lm = int L(u) Y_lm(R u) du`:
    ///
    /// - World: `L'_1-1 = L_1-1` (y, the axis), `(L'_10, L'_11) = (L_11, -L_10)` (the (x, z)
    ///   pair turned by 90 degrees), `L'_2-2 = -L_2-1`, `L'_2-1 = L_2-2`, `L'_21 = -L_21`,
    ///   `L'_20 = -L_20 / 2 + (sqrt 3 / 2) L_22`, `L'_22 = (sqrt 3 / 2) L_20 + L_22 / 2`. `L_20`
    ///   is zonal about Z, so it is *not* invariant here; `L_20 + sqrt(3) L_22`, the harmonic
    ///   zonal about Y, is.
    /// - LatLong (pole = +Y): `L_l0` invariant and `(L_lm, L_l-m)` turned by `m pi/2`, so
    ///   `L_2,+-2` change sign and `L'_1,1 = -L_1,-1`, `L'_1,-1 = L_1,1`.
    /// - Paper: World's rule with the `(-1)^(l+m)` signs.
    #[test]
    fn rotating_the_map_about_y_rotates_the_coefficients() {
        let order = 6;
        let env = lumpy(128, 64);
        let turned = rotated_quarter(&env);
        let c = |v: &[[f64; 3]], l: usize, m: isize| v[sh_index(l, m)];
        let neg = |v: [f64; 3]| v.map(|x| -x);
        let mix = |a: f64, u: [f64; 3], b: f64, v: [f64; 3]| [0, 1, 2].map(|ch| a * u[ch] + b * v[ch]);
        let (h, r3) = (0.5, 3f64.sqrt() / 2.0);
        let tol = 1e-12 * 10.0;

        let (w, w2) = (project(&env, order, ShFrame::World), project(&turned, order, ShFrame::World));
        assert!(close(c(&w2, 0, 0), c(&w, 0, 0), tol));
        assert!(close(c(&w2, 1, -1), c(&w, 1, -1), tol));
        assert!(close(c(&w2, 1, 0), c(&w, 1, 1), tol));
        assert!(close(c(&w2, 1, 1), neg(c(&w, 1, 0)), tol));
        assert!(close(c(&w2, 2, -2), neg(c(&w, 2, -1)), tol));
        assert!(close(c(&w2, 2, -1), c(&w, 2, -2), tol));
        assert!(close(c(&w2, 2, 1), neg(c(&w, 2, 1)), tol));
        assert!(close(c(&w2, 2, 0), mix(-h, c(&w, 2, 0), r3, c(&w, 2, 2)), tol));
        assert!(close(c(&w2, 2, 2), mix(r3, c(&w, 2, 0), h, c(&w, 2, 2)), tol));
        let zonal_y = |v: &[[f64; 3]]| mix(1.0, c(v, 2, 0), 3f64.sqrt(), c(v, 2, 2));
        assert!(close(zonal_y(&w2), zonal_y(&w), tol));
        assert!(!close(c(&w2, 2, 0), c(&w, 2, 0), 1e-3), "the test map has L_20 != its rotation");

        let (p, p2) = (project(&env, order, ShFrame::Paper), project(&turned, order, ShFrame::Paper));
        assert!(close(c(&p2, 1, -1), c(&p, 1, -1), tol));
        assert!(close(c(&p2, 1, 0), neg(c(&p, 1, 1)), tol));
        assert!(close(c(&p2, 1, 1), c(&p, 1, 0), tol));
        assert!(close(c(&p2, 2, 1), neg(c(&p, 2, 1)), tol));

        let (ll, ll2) = (project(&env, order, ShFrame::LatLong), project(&turned, order, ShFrame::LatLong));
        for l in 0..=order {
            assert!(close(c(&ll2, l, 0), c(&ll, l, 0), tol), "L_{l}0");
            for m in 1..=l as isize {
                // cos(m (p + pi/2)), sin(m (p + pi/2)) in terms of cos(m p), sin(m p).
                let (sn, cs) = (m as f64 * PI / 2.0).sin_cos();
                let (cs, sn) = (cs.round(), sn.round());
                let want_cos = mix(cs, c(&ll, l, m), -sn, c(&ll, l, -m));
                let want_sin = mix(sn, c(&ll, l, m), cs, c(&ll, l, -m));
                assert!(close(c(&ll2, l, m), want_cos, tol), "L_{l},{m}");
                assert!(close(c(&ll2, l, -m), want_sin, tol), "L_{l},-{m}");
            }
        }
        assert!(close(c(&ll2, 2, 2), neg(c(&ll, 2, 2)), tol));
        assert!(close(c(&ll2, 2, -2), neg(c(&ll, 2, -2)), tol));

        // Every frame: the energy per band is unchanged by any rotation.
        for frame in ShFrame::ALL {
            let (a, b) = (project(&env, order, frame), project(&turned, order, frame));
            for l in 0..=order {
                let energy = |v: &[[f64; 3]]| (0..2 * l + 1).map(|k| v[l * l + k][1].powi(2)).sum::<f64>();
                assert!((energy(&a) - energy(&b)).abs() < 1e-12 * energy(&a).max(1.0), "{frame:?} band {l}");
            }
        }
    }
}
