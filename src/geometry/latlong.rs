//! The lat-long (equirectangular) convention used everywhere in hdrflow.
//!
//! ```text
//!            x = 0          x = W/4         x = W/2          x = 3W/4          x = W
//!   y = 0    +------------------------------------------------------------------+  zenith (+Y), theta = 0
//!            |   phi = 0     phi = pi/2       phi = pi        phi = 3pi/2        |
//!            |   back +Z      left -X       forward -Z        right +X           |
//!   y = H/2  |---------------------------- horizon -----------------------------|  theta = pi/2
//!   y = H    +------------------------------------------------------------------+  nadir (-Y), theta = pi
//! ```
//!
//! - Texel (x, y) of a W x H map is centred on theta = pi*(y+0.5)/H (polar angle from +Y) and
//!   phi = 2*pi*(x+0.5)/W.
//! - Direction: d = (-sin(theta) sin(phi), cos(theta), sin(theta) cos(phi)). The centre column
//!   (phi = pi) faces forward, -Z, as in Debevec's light-probe gallery; +X is at 3/4 of the width.
//! - A texel's solid angle is (2*pi/W) * (pi/H) * sin(theta) (midpoint rule). The exact value,
//!   (2*pi/W) * (cos(theta_top) - cos(theta_bottom)), differs by O(1/H^2) relative; hdrflow uses the
//!   midpoint rule everywhere (sampling pdf, references) so that estimators and references agree
//!   exactly on the same piecewise-constant map.

use std::f64::consts::PI;

/// Polar angle theta of row `y`'s centre.
#[inline]
pub fn theta_of_row(y: usize, height: usize) -> f64 {
    PI * (y as f64 + 0.5) / height as f64
}

/// Azimuth phi of column `x`'s centre.
#[inline]
pub fn phi_of_column(x: usize, width: usize) -> f64 {
    2.0 * PI * (x as f64 + 0.5) / width as f64
}

/// Unit direction of (theta, phi).
#[inline]
pub fn direction(theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [-st * sp, ct, st * cp]
}

/// (theta, phi) of a direction (need not be normalised; a zero vector gives (0, 0)).
/// phi is in [0, 2*pi).
#[inline]
pub fn angles(d: [f64; 3]) -> (f64, f64) {
    let len = glam::DVec3::from(d).length();
    if !(len > 0.0) || !len.is_finite() {
        return (0.0, 0.0);
    }
    let theta = (d[1] / len).clamp(-1.0, 1.0).acos();
    // d = (-sin t sin p, ., sin t cos p)  =>  phi = atan2(-dx, dz)
    let mut phi = (-d[0]).atan2(d[2]);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    if phi >= 2.0 * PI {
        phi = 0.0;
    }
    (theta, phi)
}

/// The texel (x, y) that contains direction `d` on a W x H map; always in range.
#[inline]
pub fn texel_of_direction(d: [f64; 3], width: usize, height: usize) -> (usize, usize) {
    let (theta, phi) = angles(d);
    let x = ((phi / (2.0 * PI)) * width as f64).floor() as isize;
    let y = ((theta / PI) * height as f64).floor() as isize;
    (x.clamp(0, width as isize - 1) as usize, y.clamp(0, height as isize - 1) as usize)
}

/// Unit direction of texel (x, y)'s centre.
#[inline]
pub fn texel_direction(x: usize, y: usize, width: usize, height: usize) -> [f64; 3] {
    direction(theta_of_row(y, height), phi_of_column(x, width))
}

/// Solid angle of a texel in row `y` (midpoint rule): (2*pi/W) * (pi/H) * sin(theta).
#[inline]
pub fn texel_solid_angle(y: usize, width: usize, height: usize) -> f64 {
    (2.0 * PI / width as f64) * (PI / height as f64) * theta_of_row(y, height).sin()
}

/// Direction from degrees (theta, phi), as used by `view` parameters.
pub fn direction_deg(theta_deg: f64, phi_deg: f64) -> [f64; 3] {
    direction(theta_deg.to_radians(), phi_deg.to_radians())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_column_faces_forward_minus_z() {
        let d = texel_direction(512, 256, 1024, 512);
        assert!(d[2] < -0.99, "{d:?}");
        let right = direction(PI / 2.0, 1.5 * PI);
        assert!((right[0] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn texel_round_trip() {
        for &(w, h) in &[(1usize, 1usize), (4, 2), (1024, 512), (7, 3)] {
            for y in 0..h {
                for x in 0..w {
                    assert_eq!(texel_of_direction(texel_direction(x, y, w, h), w, h), (x, y));
                }
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        let (w, h) = (64, 32);
        let total: f64 = (0..h).map(|y| texel_solid_angle(y, w, h) * w as f64).sum();
        assert!((total - 4.0 * PI).abs() < 4.0 * PI * 1e-3, "{total}");
    }
}
