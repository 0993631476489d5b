//! The modified Phong lobe (E. P. Lafortune, Y. D. Willems, "Using the Modified Phong
//! Reflectance Model for Physically Based Rendering", KU Leuven report CW 197, 1994): a cosine
//! power lobe around an axis (usually the mirror direction), sampled exactly.
//!
//! With alpha the angle between a direction and the lobe axis and s >= 0 the exponent:
//! - density over solid angle: `p(alpha) = (s + 1) / (2 pi) cos^s(alpha)` for cos(alpha) > 0,
//!   0 otherwise (it integrates to 1 over the hemisphere around the axis:
//!   `int_0^{pi/2} (s+1) cos^s(a) sin(a) da = 1`);
//! - inversion: the CDF of cos(alpha) is `cos^(s+1)`, so `cos(alpha) = u1^(1/(s+1))`,
//!   `phi = 2 pi u2`.
//!
//! For large s (1e4 .. 1e6) `u1^(1/(s+1))` rounds to 1 and the angle is lost; instead
//! `1 - cos(alpha) = -expm1(ln(u1) / (s+1))` is computed directly (see `../shared/NOTES.md`),
//! and the pdf as `exp(s * ln_1p(-(1 - cos)))`. `lobe_pdf` recovers `1 - cos` from
//! `|axis - dir|^2 / 2`, which keeps its relative accuracy for tiny angles.
//!
//! Frame: T. Duff, J. Burgess, P. Christensen, C. Hery, A. Kensler, M. Liani, R. Villemin,
//! "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017 (listing 3, branchless).

use std::f64::consts::PI;

use glam::DVec3;

use crate::geometry::unit;

/// A 3-vector of f64 (x, y, z): the type of this module's interface (the arithmetic is glam's
/// `DVec3`).
pub type V3 = [f64; 3];

/// Mirror reflection of `view` about `normal`: `r = 2 (n . v) n - v` with `n` and `v`
/// normalised first (`view` points from the surface toward the viewer; so does `r`, toward the
/// mirrored side). A zero or non-finite normal is taken as +Y; a zero view as the normal (which
/// reflects to itself). The result is renormalised (unit length up to rounding).
pub fn mirror(view: V3, normal: V3) -> V3 {
    let n = unit(DVec3::from(normal)).unwrap_or(DVec3::Y);
    let v = unit(DVec3::from(view)).unwrap_or(n);
    let k = 2.0 * n.dot(v);
    unit(k * n - v).unwrap_or(n).to_array()
}

/// Two unit vectors `(b1, b2)` such that `(b1, b2, n)` is a right-handed orthonormal basis, for a
/// unit `n` (Duff et al. 2017, listing 3):
/// `sign = copysign(1, n.z); a = -1 / (sign + n.z); b = n.x n.y a;`
/// `b1 = (1 + sign n.x^2 a, sign b, -sign n.x); b2 = (b, sign + n.y^2 a, -n.y)`.
/// Continuous everywhere except across n.z = 0 and accurate to a few ulps (no singularity at
/// n = -Z, unlike Frisvad 2012).
///
/// This is glam's `DVec3::any_orthonormal_pair`, which implements the same listing operation
/// for operation (its `signum(n.z)` equals `copysign(1, n.z)` for every n.z but NaN).
#[inline]
pub fn orthonormal_basis(n: V3) -> (V3, V3) {
    let (b1, b2) = DVec3::from(n).any_orthonormal_pair();
    (b1.to_array(), b2.to_array())
}

/// The exponent as used: negative and NaN become 0, +inf is capped at 1e300 (so the pdf's
/// factor `(s+1)/(2 pi)` stays finite).
#[inline]
fn clean_exponent(s: f64) -> f64 {
    if s > 0.0 {
        s.min(1e300)
    } else {
        0.0
    }
}

/// The lobe density from `omc = 1 - cos(alpha)` (in [0, 2]):
/// `(s + 1) / (2 pi) * exp(s * ln_1p(-omc))` = `(s + 1) / (2 pi) cos^s(alpha)` for cos > 0;
/// 0 for cos < 0 and for cos = 0 when s > 0; `1 / (2 pi)` (the uniform hemisphere) for s = 0
/// on the closed hemisphere.
#[inline]
fn pdf_from_one_minus_cos(omc: f64, s: f64) -> f64 {
    if s == 0.0 {
        return if omc <= 1.0 { 1.0 / (2.0 * PI) } else { 0.0 };
    }
    if !(omc < 1.0) {
        return 0.0;
    }
    let omc = omc.max(0.0);
    (s + 1.0) / (2.0 * PI) * (s * (-omc).ln_1p()).exp()
}

/// Samples the modified Phong lobe around `axis` (need not be normalised; a zero axis is +Y)
/// with exponent `s` from `(u1, u2)` in [0, 1]^2. Returns the unit direction and its
/// solid-angle pdf `(s + 1)/(2 pi) cos^s(alpha)`.
///
/// - `1 - cos(alpha) = -expm1(ln(u1) / (s + 1))` (= `1 - u1^(1/(s+1))`, stable for large s);
/// - `sin(alpha) = sqrt((1 - cos)(1 + cos))`, `phi = 2 pi u2`;
/// - `dir = sin(alpha) (cos(phi) b1 + sin(phi) b2) + cos(alpha) axis` in the Duff et al. frame.
///
/// `u1 = 0` gives alpha = 90 degrees (pdf 0 for s > 0, 1/(2 pi) for s = 0); `u1 = 1` gives the
/// axis itself with pdf `(s+1)/(2 pi)`. u values outside [0, 1] are clamped, NaN is 0. Finite
/// and unit length for any exponent (0 .. 1e6 and beyond).
pub fn sample_lobe(axis: V3, exponent: f64, u1: f64, u2: f64) -> (V3, f64) {
    let n = unit(DVec3::from(axis)).unwrap_or(DVec3::Y);
    let s = clean_exponent(exponent);
    let u1 = if u1.is_nan() { 0.0 } else { u1.clamp(0.0, 1.0) };
    let u2 = if u2.is_nan() { 0.0 } else { u2.clamp(0.0, 1.0) };

    // ln(0) = -inf, -inf / (s+1) = -inf, expm1(-inf) = -1: omc = 1 exactly (alpha = 90 deg).
    let omc = (-(u1.ln() / (s + 1.0)).exp_m1()).clamp(0.0, 1.0);
    let cos_a = 1.0 - omc;
    let sin_a = (omc * (2.0 - omc)).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    let (sp, cp) = phi.sin_cos();
    let (b1, b2) = n.any_orthonormal_pair();
    let (ta, tb) = (sin_a * cp, sin_a * sp);
    let dir = unit(ta * b1 + tb * b2 + cos_a * n).unwrap_or(n);
    (dir.to_array(), pdf_from_one_minus_cos(omc, s))
}

/// The solid-angle density of `sample_lobe(axis, exponent, ..)` at direction `dir` (neither
/// needs to be normalised): `(s + 1)/(2 pi) cos^s(alpha)` with `1 - cos(alpha)` computed as
/// `|a - d|^2 / 2` for the unit vectors a and d (exact identity `|a - d|^2 = 2 - 2 a.d`, without
/// the cancellation of `1 - a.d` near the axis). 0 behind the lobe and for a zero `dir`.
pub fn lobe_pdf(axis: V3, dir: V3, exponent: f64) -> f64 {
    let a = unit(DVec3::from(axis)).unwrap_or(DVec3::Y);
    let Some(d) = unit(DVec3::from(dir)) else {
        return 0.0;
    };
    let omc = 0.5 * (a - d).length_squared();
    pdf_from_one_minus_cos(omc, clean_exponent(exponent))
}

/// [`lobe_pdf`] for an `axis` and a `dir` that are already unit vectors (not normalised again:
/// the per-pixel renderers call it for every sample).
#[inline]
pub(crate) fn lobe_pdf_unit(axis: DVec3, dir: DVec3, exponent: f64) -> f64 {
    pdf_from_one_minus_cos(0.5 * (axis - dir).length_squared(), clean_exponent(exponent))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::sampling::chi_square::chi_square_test;
    use crate::maths::sampling::sequences::SplitMix64;

    const EXPONENTS: [f64; 6] = [0.0, 1.0, 10.0, 200.0, 1e4, 1e6];

    fn axes() -> Vec<V3> {
        vec![
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.0, 1.0, 0.0],
            unit3([0.3, -0.5, 0.8]),
            unit3([-0.7, 0.2, -0.1]),
            [1e-9, 0.0, -1.0],
        ]
    }

    fn len(v: V3) -> f64 {
        DVec3::from(v).length()
    }

    fn dot(a: V3, b: V3) -> f64 {
        DVec3::from(a).dot(DVec3::from(b))
    }

    /// `v / |v|` (finite, non-zero `v`).
    fn unit3(v: V3) -> V3 {
        unit(DVec3::from(v)).unwrap().to_array()
    }

    #[test]
    fn mirror_reflects() {
        let r = mirror([1.0, 1.0, 0.0], [0.0, 2.0, 0.0]);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((r[0] + s).abs() < 1e-15 && (r[1] - s).abs() < 1e-15 && r[2].abs() < 1e-15, "{r:?}");
        let r = mirror([0.0, 3.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(r, [0.0, 1.0, 0.0]);
        // Reflecting twice gives the view back; the angle to the normal is preserved.
        let n = [0.2, 0.9, -0.3];
        let v = [0.5, 0.1, 0.7];
        let r = mirror(v, n);
        let back = mirror(r, n);
        let vn = unit3(v);
        let nn = unit3(n);
        for k in 0..3 {
            assert!((back[k] - vn[k]).abs() < 1e-14);
        }
        assert!((dot(r, nn) - dot(vn, nn)).abs() < 1e-14);
        assert!((len(r) - 1.0).abs() < 1e-15);
        // Degenerate inputs stay finite.
        assert!(mirror([0.0; 3], [0.0; 3]).iter().all(|c| c.is_finite()));
    }

    #[test]
    fn basis_is_orthonormal() {
        let mut rng = SplitMix64::new(1);
        let mut ns = axes();
        for _ in 0..1000 {
            let z = 2.0 * rng.next_f64() - 1.0;
            let p = 2.0 * PI * rng.next_f64();
            let r = (1.0 - z * z).sqrt();
            ns.push([r * p.cos(), r * p.sin(), z]);
        }
        for n in ns {
            let (b1, b2) = orthonormal_basis(n);
            assert!((len(b1) - 1.0).abs() < 1e-14 && (len(b2) - 1.0).abs() < 1e-14, "{n:?}");
            assert!(dot(b1, b2).abs() < 1e-14 && dot(b1, n).abs() < 1e-14 && dot(b2, n).abs() < 1e-14);
        }
    }

    #[test]
    fn unit_finite_and_consistent_for_all_exponents() {
        let mut rng = SplitMix64::new(7);
        let mut us: Vec<(f64, f64)> = vec![(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0), (1e-300, 0.5), (0.5, 0.5)];
        for _ in 0..2000 {
            us.push((rng.next_f64(), rng.next_f64()));
        }
        for axis in axes() {
            for &s in &EXPONENTS {
                for &(u1, u2) in &us {
                    let (d, pdf) = sample_lobe(axis, s, u1, u2);
                    assert!(d.iter().all(|c| c.is_finite()), "s {s} u {u1} {u2}: {d:?}");
                    assert!((len(d) - 1.0).abs() < 1e-14, "s {s}: |d| = {}", len(d));
                    assert!(pdf.is_finite() && pdf >= 0.0, "s {s}: pdf {pdf}");
                    let q = lobe_pdf(axis, d, s);
                    assert!(q.is_finite());
                    // Away from the hemisphere's rim (where cos^s is ~0 and direction rounding
                    // dominates) both densities agree to near machine precision.
                    if pdf > 1e-200 && u1 > 1e-12 {
                        let rel = (pdf - q).abs() / pdf;
                        assert!(rel < 1e-6, "s {s} axis {axis:?} u {u1} {u2}: {pdf} vs {q}");
                    }
                }
            }
        }
    }

    #[test]
    fn edge_values_of_u1() {
        for &s in &EXPONENTS {
            let axis = [0.3, -0.5, 0.8];
            let (d, pdf) = sample_lobe(axis, s, 0.0, 0.3);
            assert!(dot(d, unit3(axis)).abs() < 1e-12, "u1 = 0 must be 90 deg");
            if s > 0.0 {
                assert_eq!(pdf, 0.0);
            } else {
                assert!((pdf - 1.0 / (2.0 * PI)).abs() < 1e-15);
            }
            let (d, pdf) = sample_lobe(axis, s, 1.0, 0.3);
            let a = unit3(axis);
            assert!((dot(d, a) - 1.0).abs() < 1e-15);
            assert!((pdf - (s + 1.0) / (2.0 * PI)).abs() <= 1e-12 * (s + 1.0));
            let (d, pdf) = sample_lobe(axis, s, f64::NAN, f64::NAN);
            assert!(d.iter().all(|c| c.is_finite()) && pdf.is_finite());
        }
    }

    /// Midpoint quadrature of lobe_pdf over the whole sphere (in global coordinates, tilted axis).
    #[test]
    fn pdf_integrates_to_one() {
        let axis = unit3([0.3, 0.8, -0.5]);
        let (nt, np) = (800usize, 1600usize);
        let dt = PI / nt as f64;
        let dp = 2.0 * PI / np as f64;
        for &s in &[1.0f64, 10.0, 200.0] {
            let mut sum = 0.0;
            for i in 0..nt {
                let t = (i as f64 + 0.5) * dt;
                let (st, ct) = t.sin_cos();
                let mut row = 0.0;
                for j in 0..np {
                    let p = (j as f64 + 0.5) * dp;
                    let (sp, cp) = p.sin_cos();
                    row += lobe_pdf(axis, [st * cp, ct, st * sp], s);
                }
                sum += row * st;
            }
            sum *= dt * dp;
            assert!((sum - 1.0).abs() < 2e-3, "s = {s}: integral {sum}");
        }
    }

    /// Samples binned jointly in cos(alpha) (10 bins of equal probability through the CDF
    /// F = cos^(s+1)) and in phi (8 bins), against uniform expected counts.
    #[test]
    fn chi_square_cos_and_phi() {
        let n = 100_000usize;
        let (kc, kp) = (10usize, 8usize);
        for (ai, axis) in axes().into_iter().enumerate() {
            for &s in &[0.0f64, 1.0, 10.0, 200.0, 1e4] {
                let mut rng = SplitMix64::new(1000 + ai as u64);
                let (b1, b2) = orthonormal_basis(axis);
                let mut obs = vec![0.0; kc * kp];
                for _ in 0..n {
                    let (d, _) = sample_lobe(axis, s, rng.next_f64(), rng.next_f64());
                    let e = [axis[0] - d[0], axis[1] - d[1], axis[2] - d[2]];
                    let omc = 0.5 * dot(e, e);
                    // F = cos^(s+1) = exp((s+1) ln(1 - omc)).
                    let f = ((s + 1.0) * (-omc).ln_1p()).exp();
                    let ic = ((f * kc as f64) as usize).min(kc - 1);
                    let mut phi = dot(d, b2).atan2(dot(d, b1));
                    if phi < 0.0 {
                        phi += 2.0 * PI;
                    }
                    let ip = ((phi / (2.0 * PI) * kp as f64) as usize).min(kp - 1);
                    obs[ic * kp + ip] += 1.0;
                }
                let exp = vec![n as f64 / (kc * kp) as f64; kc * kp];
                let r = chi_square_test(&obs, &exp, 5.0);
                assert!(r.passed(1e-4), "axis {axis:?} s {s}: {r:?}");
            }
        }
    }
}
