//! The real SH basis: coefficient indexing and evaluation of every `Y_lm` of a direction by the
//! normalised Legendre recurrences (the "Basis" and "Evaluation" sections of the [parent
//! module](super)). Kept apart from projection and irradiance because every other SH file
//! builds on it and it depends on none of them.

use std::f64::consts::{PI, SQRT_2};

use crate::values::ShFrame;

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
pub(super) fn legendre_q(order: usize, x: f64, out: &mut [f64]) {
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
pub(super) fn eval_basis(order: usize, [x, y, z]: [f64; 3], out: &mut [f64]) {
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

/// The name of coefficient `(l, m)`, channel `ch` (0, 1, 2 = r, g, b) in a metrics record:
/// `L_{l}_{m}_{r|g|b}`, e.g. `L_0_0_r`, `L_1_-1_g`.
pub fn coefficient_name(l: usize, m: isize, ch: usize) -> String {
    format!("L_{l}_{m}_{}", ["r", "g", "b"][ch])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;
    use crate::maths::ibl::sh::frames::gauss_legendre;
    use crate::maths::ibl::sh::test_support::random_dir;
    use crate::maths::sampling::sequences::SplitMix64;

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
}
