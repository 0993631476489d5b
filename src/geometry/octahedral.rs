//! pbrt-v4's equal-area octahedral mapping of the sphere onto the unit square (P. Clarberg, "Fast
//! Equal-Area Mapping of the (Hemi)Sphere using SIMD", JGT 2008; pbrt-v4 `src/pbrt/util/math.cpp`
//! `EqualAreaSquareToSphere` and `EqualAreaSphereToSquare`, the layout pbrt-v4's
//! `ImageInfiniteLight` requires and `imgtool makeequiarea` writes).
//!
//! With `u = 2 p_x - 1`, `v = 2 p_y - 1`, the signed distance from the diagonal
//! `s = 1 - (|u| + |v|)`, `r = 1 - |s|` and `phi = ((|v| - |u|) / r + 1) pi / 4`:
//!
//! ```text
//! z = sign(s) (1 - r^2),   x = sign(u) cos(phi) r sqrt(2 - r^2),   y = sign(v) sin(phi) r sqrt(2 - r^2)
//! ```
//!
//! The Jacobian is constant: every region of the square of area A maps to solid angle 4 pi A
//! (test), so the N x N texels of an octahedral image all subtend 4 pi / N^2. pbrt approximates
//! `atan` in the inverse by a degree-7 polynomial; hdrflow uses `atan` itself (same mapping,
//! exact to rounding: the round trip test holds to 1e-12).
//!
//! **Axes.** pbrt's (x, y, z) above are the light's frame, z up. hdrflow's world is +Y up, -Z
//! forward; the mapping used here is `pbrt = (Z, -X, Y)` of hdrflow's (X, Y, Z) (the `LatLong`
//! frame of `maths::ibl::sh`): it is the frame in which a lat-long map's theta and phi are pbrt's
//! `SphericalTheta` (from +z) and `SphericalPhi` (from +x towards +y), so an hdrflow lat-long map
//! given to `imgtool makeequiarea` and the same map through `LatLongToOctahedral` agree. Pixel
//! (x, y) of an N x N image (row 0 at the top) is centred on `p = ((x + 0.5) / N, (y + 0.5) / N)`,
//! as in `makeequiarea`.

use std::f64::consts::PI;

use glam::DVec3;

/// pbrt's `EqualAreaSquareToSphere`: p in [0, 1]^2 to a unit vector of pbrt's frame (z up).
pub fn square_to_sphere_pbrt(p: [f64; 2]) -> DVec3 {
    let u = 2.0 * p[0] - 1.0;
    let v = 2.0 * p[1] - 1.0;
    let (up, vp) = (u.abs(), v.abs());
    let signed_distance = 1.0 - (up + vp);
    let d = signed_distance.abs();
    let r = 1.0 - d;
    let phi = (if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 }) * PI / 4.0;
    let z = (1.0 - r * r).copysign(signed_distance);
    let cos_phi = phi.cos().copysign(u);
    let sin_phi = phi.sin().copysign(v);
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    DVec3::new(cos_phi * s, sin_phi * s, z)
}

/// pbrt's `EqualAreaSphereToSquare`: a unit vector of pbrt's frame to p in [0, 1]^2.
pub fn sphere_to_square_pbrt(d: DVec3) -> [f64; 2] {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let a = x.max(y);
    let b = if a == 0.0 { 0.0 } else { x.min(y) / a };
    // phi / (pi / 2) in [0, 1] for the first octant half (pbrt: a polynomial fit of this).
    let mut phi = b.atan() * 2.0 / PI;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        std::mem::swap(&mut u, &mut v);
        u = 1.0 - u;
        v = 1.0 - v;
    }
    u = u.copysign(d.x);
    v = v.copysign(d.y);
    [0.5 * (u + 1.0), 0.5 * (v + 1.0)]
}

/// hdrflow world direction -> pbrt's light frame: `(Z, -X, Y)`.
#[inline]
pub fn world_to_pbrt(d: DVec3) -> DVec3 {
    DVec3::new(d.z, -d.x, d.y)
}

/// pbrt's light frame -> hdrflow world: the inverse of [`world_to_pbrt`].
#[inline]
pub fn pbrt_to_world(d: DVec3) -> DVec3 {
    DVec3::new(-d.y, d.z, d.x)
}

/// The hdrflow world direction of square point p.
#[inline]
pub fn square_to_direction(p: [f64; 2]) -> DVec3 {
    pbrt_to_world(square_to_sphere_pbrt(p))
}

/// The square point of an hdrflow world direction (normalised here; zero gives the centre).
#[inline]
pub fn direction_to_square(d: DVec3) -> [f64; 2] {
    let len = d.length();
    if !(len > 0.0) || !len.is_finite() {
        return [0.5, 0.5];
    }
    sphere_to_square_pbrt(world_to_pbrt(d / len))
}

/// The pixel (x, y) of an N x N octahedral image that contains direction d; always in range.
#[inline]
pub fn texel_of_direction(d: DVec3, n: usize) -> (usize, usize) {
    let p = direction_to_square(d);
    let f = |t: f64| ((t * n as f64).floor() as isize).clamp(0, n as isize - 1) as usize;
    (f(p[0]), f(p[1]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_both_ways() {
        let n = 97;
        for j in 0..n {
            for i in 0..n {
                let p = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                let d = square_to_direction(p);
                assert!((d.length() - 1.0).abs() < 1e-12);
                let q = direction_to_square(d);
                assert!((q[0] - p[0]).abs() < 1e-12 && (q[1] - p[1]).abs() < 1e-12, "{p:?} -> {q:?}");
                assert_eq!(texel_of_direction(d, n), (i, j));
            }
        }
        // pbrt's z is hdrflow's +Y: the square's centre looks up, its corners down.
        assert!((square_to_direction([0.5, 0.5]) - DVec3::Y).length() < 1e-12);
        assert!((square_to_direction([0.0, 0.0]) + DVec3::Y).length() < 1e-12);
    }

    /// Equal area: the solid angle of a texel, integrated on a fine lat-long grid of directions
    /// mapped back into the square, is 4 pi / N^2 for every texel (to the grid's resolution).
    #[test]
    fn texels_have_equal_solid_angle() {
        let n = 4;
        let (w, h) = (2048, 1024);
        let mut area = vec![0.0f64; n * n];
        for y in 0..h {
            for x in 0..w {
                let d = DVec3::from(crate::geometry::latlong::texel_direction(x, y, w, h));
                let (i, j) = texel_of_direction(d, n);
                area[j * n + i] += crate::geometry::latlong::texel_solid_angle(y, w, h);
            }
        }
        let want = 4.0 * PI / (n * n) as f64;
        for a in area {
            assert!((a - want).abs() < 2e-3 * want, "{a} vs {want}");
        }
    }
}
