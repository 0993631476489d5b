//! Lat-long angles of a direction without libm's `acos` and `atan2`, for the hot loop of the cut
//! cells (`maths::resample::cut_cells`, where they took about a third of the time).
//!
//! `atan2(y, x)`: with `a = min(|x|, |y|) / max(|x|, |y|)` in [0, 1], `atan a` is
//! `t P(t^2)` for `t = a` when `a <= tan(pi/8)`, else `pi/4 + t P(t^2)` for
//! `t = (a - 1) / (a + 1)` (so `|t| <= tan(pi/8)` always), then the octant and quadrant are
//! restored (`pi/2 - r`, `pi - r`, the sign of y). `P` is a degree-10 polynomial in `t^2`, a
//! least-squares Chebyshev fit of `atan(sqrt x) / sqrt x` on `[0, tan^2(pi/8)]` (weight
//! `sqrt x`, 4000 Chebyshev nodes, numpy); its own error is 7.2e-16 rad. A zero vector takes
//! libm's `atan2`, whose signed zeros the callers' conventions rely on.
//!
//! `(theta, phi)` of `latlong::angles` as `theta = atan2(sqrt(x^2 + z^2), y)` (no `acos`, no
//! normalisation: more accurate than `acos`, off by 2e-16 / sin theta near the poles) and
//! `phi = atan2(-x, z)` in [0, 2 pi). Tested: within 2e-15 rad of libm's `atan2` on every octant
//! and near the axes.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

pub mod lanes;

/// tan(pi / 8) = sqrt(2) - 1.
const TAN_PI_8: f64 = 0.414_213_562_373_095_03;

/// `P(x)`, lowest degree first (module docs).
const P: [f64; 11] = [
    1.0000000000000002,
    -0.33333333333341625,
    0.20000000001111895,
    -0.14285714261833118,
    0.11111106167465028,
    -0.09090718213736056,
    0.07688660113457804,
    -0.06626087346262396,
    0.056052477055747375,
    -0.04094553623388705,
    0.017977467664841346,
];

/// `atan t` for `|t| <= tan(pi/8)`.
#[inline]
fn atan_small(t: f64) -> f64 {
    let x = t * t;
    let mut p = P[10];
    for &c in P[..10].iter().rev() {
        // Not `mul_add`: without the FMA target feature it is a call to a software fma.
        p = p * x + c;
    }
    t * p
}

/// `atan2(y, x)` to 2e-15 rad (module docs).
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if !(hi > 0.0) || !hi.is_finite() {
        return y.atan2(x);
    }
    let a = lo / hi;
    let r = if a > TAN_PI_8 { FRAC_PI_4 + atan_small((a - 1.0) / (a + 1.0)) } else { atan_small(a) };
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    // The sign bit, as libm: atan2(-0, x < 0) = -pi.
    if y.is_sign_negative() {
        -r
    } else {
        r
    }
}

/// `(theta, phi)` of direction `d` (need not be normalised), as `latlong::angles` gives them
/// to 2e-15 rad; phi in [0, 2 pi).
#[inline]
pub fn latlong_angles(d: [f64; 3]) -> (f64, f64) {
    let [x, y, z] = d;
    let theta = atan2((x * x + z * z).sqrt(), y);
    let mut phi = atan2(-x, z);
    if phi < 0.0 {
        phi += TAU;
    }
    if phi >= TAU {
        phi = 0.0;
    }
    (theta, phi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;

    #[test]
    fn atan2_and_the_angles_agree_with_libm_to_2e_15() {
        let (mut worst_atan, mut worst_angles) = (0.0f64, 0.0f64);
        let mut rng = crate::maths::sampling::sequences::SplitMix64::new(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next_f64() * 2.0 - 1.0;
        let specials = [0.0, 1e-300, 1e-9, TAN_PI_8, 1.0, 1.0 - 1e-16];
        for i in 0..200_000 {
            let (mut y, mut x) = (next(), next());
            if i < 36 {
                (y, x) = (specials[i % 6], specials[i / 6] + 1e-12);
            }
            for (yy, xx) in [(y, x), (-y, x), (y, -x), (-y, -x), (x, y)] {
                worst_atan = worst_atan.max((atan2(yy, xx) - yy.atan2(xx)).abs());
            }
            let near = if i % 7 == 0 { 1e-6 } else { 1.0 };
            let d = if i % 2 == 0 { [next(), next() * near, next()] } else { [next() * near, next(), next() * near] };
            let (t, p) = latlong_angles(d);
            // libm's theta by the same formula: `latlong::angles`' `acos(y / |d|)` is itself off
            // by its argument's rounding over sin theta (2e-16 / sin theta) near the poles.
            let (_, p0) = latlong::angles(d);
            let t0 = (d[0] * d[0] + d[2] * d[2]).sqrt().atan2(d[1]);
            let dp = (p - p0).abs();
            worst_angles = worst_angles.max((t - t0).abs()).max(dp.min(TAU - dp));
        }
        eprintln!("atan2 {worst_atan:e}, angles {worst_angles:e}");
        assert!(worst_atan < 2e-15 && worst_angles < 2e-15, "atan2 {worst_atan:e}, angles {worst_angles:e}");
        assert_eq!(latlong_angles([0.0, 1.0, 0.0]), (0.0, 0.0));
        assert_eq!(latlong_angles([0.0, -2.0, 0.0]).0, PI);
    }
}
