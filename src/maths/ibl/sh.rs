//! Real spherical harmonics (SH) of any order, projection of a lat-long map onto them in a
//! chosen frame, and the irradiance environment map of Ramamoorthi and Hanrahan.
//!
//! # The basis
//!
//! For band `l >= 0` and `-l <= m <= l`, as a function of a unit vector `(x, y, z)` with polar
//! angle `t` from +z and azimuth `p` from +x towards +y (`x = sin t cos p`, `y = sin t sin p`,
//! `z = cos t`):
//!
//! ```text
//! Y_l0  = K_l^0 P_l^0(z)
//! Y_lm  = sqrt(2) K_l^m cos(m p) P_l^m(z)        m > 0
//! Y_l-m = sqrt(2) K_l^m sin(m p) P_l^m(z)        m > 0
//! K_l^m = sqrt((2l + 1) / (4 pi) * (l - m)! / (l + m)!)
//! ```
//!
//! with `P_l^m` the associated Legendre polynomials *without* the Condon-Shortley phase
//! (`P_m^m = (2m - 1)!! (1 - z^2)^(m/2)`). Up to order 2 this is Ramamoorthi and Hanrahan's
//! table (2001, eq. 3), the same polynomials as three.js `SphericalHarmonics3.getBasisAt`:
//!
//! ```text
//! Y_00  = 1 / (2 sqrt(pi))             = 0.282095
//! Y_1-1 = sqrt(3) / (2 sqrt(pi))  y    = 0.488603 y
//! Y_10  = sqrt(3) / (2 sqrt(pi))  z    = 0.488603 z
//! Y_11  = sqrt(3) / (2 sqrt(pi))  x    = 0.488603 x
//! Y_2-2 = sqrt(15) / (2 sqrt(pi)) xy   = 1.092548 xy
//! Y_2-1 = sqrt(15) / (2 sqrt(pi)) yz   = 1.092548 yz
//! Y_20  = sqrt(5) / (4 sqrt(pi))  (3z^2 - 1) = 0.315392 (3z^2 - 1)
//! Y_21  = sqrt(15) / (2 sqrt(pi)) xz   = 1.092548 xz
//! Y_22  = sqrt(15) / (4 sqrt(pi)) (x^2 - y^2) = 0.546274 (x^2 - y^2)
//! ```
//!
//! The basis is orthonormal over the sphere. Coefficients are stored at index `l (l + 1) + m`
//! ([`sh_index`]), `(L + 1)^2` of them for order `L` ([`sh_count`]). Definitions: P.-P. Sloan,
//! "Stupid Spherical Harmonics (SH) Tricks", GDC 2008 (which keeps the Condon-Shortley phase: his
//! odd-m functions have the opposite sign, as have Filament's raw `cmgen --sh` coefficients);
//! R. Green, "Spherical Harmonic Lighting: The Gritty Details", GDC 2003.
//!
//! # Frames
//!
//! Which axes `(x, y, z)` are in hdrflow's world ([`ShFrame`]; `d` a unit direction, world +Y
//! up, -Z forward, +X right, the lat-long convention of [`crate::geometry::latlong`]:
//! `d = (-sin t sin p, cos t, sin t cos p)` for the map's theta and phi):
//!
//! ```text
//! World    (x, y, z) = ( d_x, d_y,  d_z)   hdrflow's axes, Y up; three.js, Filament
//! Paper    (x, y, z) = ( d_x, d_y, -d_z)   Ramamoorthi-Hanrahan for a Debevec probe, z forward
//! LatLong  (x, y, z) = ( d_z, -d_x, d_y)   z up, p = the map's phi (ShIrradiance version 1)
//! ```
//!
//! `World` is what a Y-up engine evaluates with a world-space normal: three.js
//! `SphericalHarmonics3` (`0.488603 * y`, `* z`, `* x` in slots 1, 2, 3) and Filament's 3-band
//! irradiance SH (`computeIrradianceSH3Bands`, shader `Irradiance_SphericalHarmonics`: `n.y`,
//! `n.z`, `n.x`, ...). Its polar axis is Z, so `L_1,-1` is the up component and `L_20` is zonal
//! about the forward-back axis. `Paper` is the frame Ramamoorthi and Hanrahan's published
//! Grace Cathedral coefficients are expressed in (computed from Debevec's angular probe): z
//! towards the probe's centre, that is forward, x right, y up. hdrflow's `Paper` coefficients of
//! `grace_probe.hdr` match their 27 numbers to 0.005 once each channel is scaled by its `L_00`
//! (`tests/sh_frames.rs`); in the `LatLong` frame, which version 1 of `ShIrradiance` used and
//! documented as theirs, 20 of the 27 differ in place or sign. `Paper` is a mirror image of
//! `World` (z reversed), so `L_lm(Paper) = (-1)^(l + m) L_lm(World)`, since
//! `P_l^m(-z) = (-1)^(l + m) P_l^m(z)`. `LatLong` puts the pole on the map's pole, so rotating
//! the map about +Y by `a` (its columns shifted by `a W / (2 pi)`) keeps `L_l0` and turns each
//! pair `(L_lm, L_l-m)` by `m a`; it is the frame hdrflow projects in (below) and the one
//! `ShSphere` works in. `Paper` and `LatLong` are left-handed in hdrflow's right-handed world
//! (determinant -1), so no rotation maps `World` onto them: the change of frame is an
//! orthogonal map per band that includes a reflection.
//!
//! # Evaluation
//!
//! The normalised polynomials `Pbar_l^m = K_l^m P_l^m` are computed directly, which never forms
//! the factorials (no overflow at high order): with `s = sin t`, `Pbar_l^m = s^m Q_l^m(z)` and
//!
//! ```text
//! Q_0^0 = 1 / sqrt(4 pi)
//! Q_m^m = sqrt((2m + 1) / (2m)) Q_{m-1}^{m-1}
//! Q_{m+1}^m = sqrt(2m + 3) z Q_m^m
//! Q_l^m = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m),  a_lm = sqrt((4l^2 - 1) / (l^2 - m^2)),
//!                                               b_lm = sqrt(((l-1)^2 - m^2) / (4(l-1)^2 - 1))
//! ```
//!
//! These are the three-term recurrences of the unnormalised `P_l^m` (Green 2003; Sloan 2008;
//! pbrt-v2 `core/sh.cpp`: `P_m^m = (2m-1)!! s^m`, `P_{m+1}^m = z (2m+1) P_m^m`,
//! `(l - m) P_l^m = z (2l - 1) P_{l-1}^m - (l + m - 1) P_{l-2}^m`) multiplied through by `K_l^m`
//! (the form used for very high degrees in geodesy: S. A. Holmes, W. E. Featherstone, J. Geodesy
//! 76, 2002). The azimuthal factors `s^m cos(m p)` and `s^m sin(m p)` are the real and imaginary
//! parts of `(x + i y)^m`, so a direction is evaluated without trigonometry and exactly at the
//! poles. The tests check the recurrence against the factorial form up to l = 8 and
//! orthonormality by exact (Gauss-Legendre) quadrature.
//!
//! # Irradiance (Ramamoorthi and Hanrahan 2001)
//!
//! R. Ramamoorthi, P. Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
//! SIGGRAPH 2001, eqs. 7-9: the irradiance is the radiance convolved with the clamped cosine, a
//! zonal kernel, so by the Funk-Hecke theorem each band is scaled by one number:
//!
//! ```text
//! E(n) = sum_l A_l sum_m L_lm Y_lm(n)
//! A_0 = pi, A_1 = 2 pi / 3, A_l = 0 for odd l > 1,
//! A_l = 2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) * l! / (2^l ((l/2)!)^2)  for even l
//! ```
//!
//! (A_2 = pi/4, A_4 = -pi/24, A_6 = pi/64.) `E` does not depend on the frame, as long as `L_lm`
//! and `Y_lm(n)` use the same one. Order 2 (9 coefficients) is their irradiance map: the
//! truncation error of the kernel is small for smooth lighting (they report ~1% average, < 9%
//! worst for their maps), and large for a small bright source, whose energy is spread over all
//! bands (a sun gives rings and negative values opposite to it). Results are not clamped.
//!
//! # Projection
//!
//! `L_lm = sum_texels L_i Y_lm(d_i) dOmega_i` (midpoint rule with hdrflow's texel solid angle,
//! the same quadrature as `reference::irradiance_exact`), in f64, first in the `LatLong` frame:
//! per row the sum over columns is a short Fourier sum (`sum_x L cos(m phi_x)`,
//! `sum_x L sin(m phi_x)`), multiplied by the row's `Pbar_l^m`: O(W H (L + 1)) work, rows in
//! parallel, row results added in row order (so independent of the number of threads). Another
//! frame's coefficients are then, band by band, `L'_l = T_l L_l` with
//! `T_l[m][m'] = int Y_lm(frame axes of d) Y_lm'(LatLong axes of d) dd` ([`frame_matrices`]):
//! `Y_lm` of the new axes is a combination of the band-`l` functions of the old ones, since the
//! axes are an orthogonal transform of each other, so this equals the midpoint sum taken
//! directly in the new axes (a test checks it against that sum). `T_l` is computed by exact
//! quadrature (Gauss-Legendre in `z` times equally spaced azimuths: the integrand is a
//! polynomial of degree `2l`), and entries within 1e-13 of 0 or +-1 are set to exactly that
//! (so `L_00` is unchanged and band 1 is an exact signed permutation).

use std::f64::consts::{PI, SQRT_2};

use rayon::prelude::*;

use crate::geometry::latlong;
use crate::maths::render::relight::SphereView;
use crate::values::{Image, ShFrame};

/// Number of coefficients of order `order` (bands 0..=order): `(order + 1)^2`.
#[inline]
pub fn sh_count(order: usize) -> usize {
    (order + 1) * (order + 1)
}

/// Index of `Y_lm` (`|m| <= l`): `l (l + 1) + m`.
#[inline]
pub fn sh_index(l: usize, m: isize) -> usize {
    debug_assert!(m.unsigned_abs() <= l);
    ((l * (l + 1)) as isize + m) as usize
}

/// The `(l, m)` of coefficient index `i` (inverse of [`sh_index`]).
pub fn sh_lm(i: usize) -> (usize, isize) {
    let mut l = (i as f64).sqrt() as usize;
    while l * l > i {
        l -= 1;
    }
    while (l + 1) * (l + 1) <= i {
        l += 1;
    }
    (l, i as isize - (l * (l + 1)) as isize)
}

/// `Q_l^m(z)` for `0 <= m <= l <= order` (see the module documentation), written at
/// `out[sh_index(l, m)]` (the `m < 0` slots are left untouched).
fn legendre_q(order: usize, x: f64, out: &mut [f64]) {
    let idx = |l: usize, m: usize| l * (l + 1) + m;
    out[0] = 0.5 / PI.sqrt();
    for m in 0..=order {
        if m > 0 {
            let mf = m as f64;
            out[idx(m, m)] = ((2.0 * mf + 1.0) / (2.0 * mf)).sqrt() * out[idx(m - 1, m - 1)];
        }
        if m < order {
            out[idx(m + 1, m)] = (2.0 * m as f64 + 3.0).sqrt() * x * out[idx(m, m)];
        }
        for l in m + 2..=order {
            let (lf, mf) = (l as f64, m as f64);
            let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
            let b = (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0)).sqrt();
            out[idx(l, m)] = a * (x * out[idx(l - 1, m)] - b * out[idx(l - 2, m)]);
        }
    }
}

/// All `Y_lm(x, y, z)` for `l <= order` into `out` (`sh_count(order)` entries), for a unit
/// vector given in the basis' own axes.
fn eval_basis(order: usize, [x, y, z]: [f64; 3], out: &mut [f64]) {
    legendre_q(order, z, out);
    // (c, s) = real and imaginary parts of (x + i y)^m = s^m (cos m p, sin m p).
    let (mut c, mut s) = (1.0f64, 0.0f64);
    for m in 1..=order {
        let c_next = x * c - y * s;
        s = x * s + y * c;
        c = c_next;
        for l in m..=order {
            let base = l * (l + 1);
            let q = out[base + m];
            out[base + m] = SQRT_2 * q * c;
            out[base - m] = SQRT_2 * q * s;
        }
    }
}

/// All `Y_lm(d)` for `l <= order`, in `frame`'s axes, into `out` (`sh_count(order)` entries).
/// `d` is a direction of hdrflow's world, normalised here; a zero or non-finite `d` gives NaN
/// everywhere.
pub fn eval_sh_into(frame: ShFrame, order: usize, d: [f64; 3], out: &mut [f64]) {
    let out = &mut out[..sh_count(order)];
    let len = glam::DVec3::from(d).length();
    if !(len > 0.0) || !len.is_finite() {
        out.fill(f64::NAN);
        return;
    }
    eval_basis(order, frame.axes([d[0] / len, d[1] / len, d[2] / len]), out);
}

/// All `Y_lm(d)` for `l <= order` in `frame`'s axes (`sh_count(order)` values, index
/// [`sh_index`]).
pub fn eval_sh(frame: ShFrame, order: usize, d: [f64; 3]) -> Vec<f64> {
    let mut out = vec![0.0; sh_count(order)];
    eval_sh_into(frame, order, d, &mut out);
    out
}

/// Gauss-Legendre nodes and weights on [-1, 1], exact for polynomials of degree `2n - 1`
/// (Newton on `P_n` from the Chebyshev guess; Press et al., *Numerical Recipes* 3rd ed.,
/// section 4.6, `gauleg`).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
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
fn project_latlong(env: &Image, order: usize, phi_shift: f64) -> Vec<[f64; 3]> {
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

/// The name of coefficient `(l, m)`, channel `ch` (0, 1, 2 = r, g, b) in a metrics record:
/// `L_{l}_{m}_{r|g|b}`, e.g. `L_0_0_r`, `L_1_-1_g`.
pub fn coefficient_name(l: usize, m: isize, ch: usize) -> String {
    format!("L_{l}_{m}_{}", ["r", "g", "b"][ch])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::render::reference::irradiance_exact;
    use crate::maths::render::reference::tests::{fibonacci, map};
    use crate::maths::sampling::sequences::SplitMix64;

    fn random_dir(rng: &mut SplitMix64) -> [f64; 3] {
        let z = 1.0 - 2.0 * rng.next_f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * rng.next_f64();
        [r * phi.cos(), r * phi.sin(), z]
    }

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
    fn index_round_trip() {
        let mut i = 0;
        for l in 0..=10usize {
            for m in -(l as isize)..=l as isize {
                assert_eq!(sh_index(l, m), i);
                assert_eq!(sh_lm(i), (l, m));
                i += 1;
            }
        }
        assert_eq!(sh_count(10), i);
        assert_eq!(coefficient_name(1, -1, 1), "L_1_-1_g");
    }

    /// Ramamoorthi and Hanrahan 2001, eq. 3 (constants to 6 digits), in every frame's axes.
    #[test]
    fn first_bands_match_ramamoorthi_hanrahan_table() {
        let mut rng = SplitMix64::new(1);
        for (frame, d) in ShFrame::ALL.iter().flat_map(|f| (0..200).map(move |_| f)).map(|f| (f, random_dir(&mut rng)))
        {
            let [x, y, z] = match frame {
                ShFrame::World => [d[0], d[1], d[2]],
                ShFrame::Paper => [d[0], d[1], -d[2]],
                ShFrame::LatLong => [d[2], -d[0], d[1]],
            };
            let want = [
                0.282095,
                0.488603 * y,
                0.488603 * z,
                0.488603 * x,
                1.092548 * x * y,
                1.092548 * y * z,
                0.315392 * (3.0 * z * z - 1.0),
                1.092548 * x * z,
                0.546274 * (x * x - y * y),
            ];
            let got = eval_sh(*frame, 2, d);
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!((g - w).abs() < 2e-6, "{frame:?} {i}: {g} vs {w}");
            }
        }
    }

    /// The factorial form (Sloan 2008, appendix 2), no Condon-Shortley phase, from the angles of
    /// the lat-long map (so in the `LatLong` frame).
    fn y_factorial(l: usize, m: isize, d: [f64; 3]) -> f64 {
        let (theta, phi) = latlong::angles(d);
        let x = theta.cos();
        let am = m.unsigned_abs();
        // P_l^|m|(x) by the unnormalised recurrence.
        let mut pmm = 1.0f64;
        let s = (1.0 - x * x).max(0.0).sqrt();
        for k in 1..=am {
            pmm *= (2 * k - 1) as f64 * s;
        }
        let p = if l == am {
            pmm
        } else {
            let mut p0 = pmm;
            let mut p1 = x * (2 * am + 1) as f64 * pmm;
            for ll in am + 2..=l {
                let p2 = (x * (2 * ll - 1) as f64 * p1 - (ll + am - 1) as f64 * p0) / (ll - am) as f64;
                p0 = p1;
                p1 = p2;
            }
            p1
        };
        let fact = |n: usize| (1..=n).map(|k| k as f64).product::<f64>();
        let k = ((2 * l + 1) as f64 / (4.0 * PI) * fact(l - am) / fact(l + am)).sqrt();
        match m.signum() {
            0 => k * p,
            1 => SQRT_2 * k * (am as f64 * phi).cos() * p,
            _ => SQRT_2 * k * (am as f64 * phi).sin() * p,
        }
    }

    #[test]
    fn normalised_recurrence_matches_factorial_form_to_order_8() {
        let mut rng = SplitMix64::new(2);
        let mut dirs: Vec<[f64; 3]> = (0..300).map(|_| random_dir(&mut rng)).collect();
        dirs.extend([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [3.0, 4.0, 0.0]]);
        for d in dirs {
            let got = eval_sh(ShFrame::LatLong, 8, d);
            assert_eq!(got.len(), sh_count(8));
            for (i, g) in got.iter().enumerate() {
                let (l, m) = sh_lm(i);
                let want = y_factorial(l, m, d);
                assert!((g - want).abs() < 1e-12, "Y_{l},{m}({d:?}): {g} vs {want}");
            }
        }
        for frame in ShFrame::ALL {
            assert!(eval_sh(frame, 2, [0.0; 3]).iter().all(|v| v.is_nan()));
        }
    }

    /// Exact quadrature: Gauss-Legendre in cos(theta) (16 nodes: exact to degree 31) times 40
    /// equally spaced phi (exact for frequencies below 40); Y_i Y_j with l <= 8 has degree <= 16
    /// and frequency <= 16.
    #[test]
    fn orthonormal_by_exact_quadrature_to_order_8() {
        let order = 8;
        let count = sh_count(order);
        for frame in ShFrame::ALL {
            orthonormal_in(frame, order, count);
        }
    }

    fn orthonormal_in(frame: ShFrame, order: usize, count: usize) {
        let mut gram = vec![0.0f64; count * count];
        let nphi = 40;
        for (x, wx) in gauss_legendre(16) {
            let s = (1.0 - x * x).sqrt();
            for k in 0..nphi {
                let phi = 2.0 * PI * (k as f64 + 0.3) / nphi as f64;
                let d = [-s * phi.sin(), x, s * phi.cos()];
                let y = eval_sh(frame, order, d);
                let w = wx * 2.0 * PI / nphi as f64;
                for i in 0..count {
                    for j in 0..count {
                        gram[i * count + j] += w * y[i] * y[j];
                    }
                }
            }
        }
        for i in 0..count {
            for j in 0..count {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (gram[i * count + j] - want).abs() < 1e-12,
                    "{frame:?}: <Y{:?}, Y{:?}> = {}",
                    sh_lm(i),
                    sh_lm(j),
                    gram[i * count + j]
                );
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

    /// The built-in sky's gradient and ground without its sun, blended across the horizon over
    /// +-0.1 in d_y (~6 degrees) so it is smooth.
    fn smooth_sky(w: usize, h: usize) -> Image {
        let zenith = [0.2, 0.35, 0.8];
        let horizon = [0.8, 0.85, 0.9];
        let ground = [0.14, 0.15, 0.08];
        map(w, h, move |d| {
            let t = d[1].max(0.0).sqrt();
            let sky = [0, 1, 2].map(|c| horizon[c] + (zenith[c] - horizon[c]) * t);
            let u = ((d[1] + 0.1) / 0.2).clamp(0.0, 1.0);
            let b = u * u * (3.0 - 2.0 * u); // smoothstep
            [0, 1, 2].map(|c| ground[c] + (sky[c] - ground[c]) * b)
        })
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

    #[test]
    fn projection_is_independent_of_thread_count() {
        let env = smooth_sky(128, 64);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        for frame in ShFrame::ALL {
            let one = pool.install(|| project(&env, 6, frame));
            assert_eq!(one, project(&env, 6, frame));
        }
    }

    /// A smooth map with something in every band and no symmetry: a gradient and two lobes.
    fn lumpy(w: usize, h: usize) -> Image {
        let a = glam::DVec3::new(0.6, 0.5, -0.62).normalize();
        let b = glam::DVec3::new(-0.3, -0.2, 0.93).normalize();
        map(w, h, move |d| {
            let v = glam::DVec3::from(d);
            let lobe = |c: glam::DVec3, k: i32| v.dot(c).max(0.0).powi(k);
            let s = 1.0 + 0.3 * d[0] - 0.2 * d[1] + 0.1 * d[2] + 2.0 * lobe(a, 6) + 0.7 * lobe(b, 3);
            [s, 0.5 * s + 0.4 * lobe(b, 2), 2.0 - 0.5 * d[0] * d[2]]
        })
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

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|ch| (a[ch] - b[ch]).abs() <= tol)
    }

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
