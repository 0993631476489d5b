//! The cube-map convention used by hdrflow: six square faces in the OpenGL / KTX order
//! +X, -X, +Y, -Y, +Z, -Z, expressed in hdrflow's world axes (+Y up, -Z forward, +X right: the
//! lat-long convention of [`super::latlong`]; the centre of a lat-long map, phi = pi, looks down
//! -Z, and its left and right edges, phi = 0, look down +Z).
//!
//! A face texel (x, y) of an S x S face (row y = 0 at the top of the stored face image) has face
//! coordinates `a = 2 (x + 0.5) / S - 1`, `b = 2 (y + 0.5) / S - 1`, and the direction
//! (OpenGL 4.6 specification, table 8.19, with `s = (a + 1) / 2`, `t = (b + 1) / 2`):
//!
//! ```text
//! face  index  direction (a, b in [-1, 1])   a grows towards   b (rows) grow towards
//! +X    0      ( 1, -b, -a)                  -Z                -Y
//! -X    1      (-1, -b,  a)                  +Z                -Y
//! +Y    2      ( a,  1,  b)                  +X                +Z
//! -Y    3      ( a, -1, -b)                  +X                -Z
//! +Z    4      ( a, -b,  1)                  +X                -Y
//! -Z    5      (-a, -b, -1)                  -X                -Y
//! ```
//!
//! So the four side faces are stored upright (row 0 towards +Y). The texel order is face by face,
//! row by row, which is also the memory order of a KTX2 cube map's level and of the horizontal
//! strip `Save` writes (the faces side by side, +X first).
//!
//! Solid angle: the face point (a, b) is the point (a, b, 1) of the plane at distance 1, so
//! `dOmega = da db / (1 + a^2 + b^2)^(3/2)`, whose integral over [0, a] x [0, b] is
//! `F(a, b) = atan(a b / sqrt(1 + a^2 + b^2))` (e.g. M. Ehlers, "Cube map texel solid angle",
//! 2009; cmft `texelSolidAngle`). A texel's solid angle is the exact
//! `F(a1, b1) - F(a0, b1) - F(a1, b0) + F(a0, b0)`, and the 6 S^2 texels sum to 4 pi to rounding
//! (test).

use glam::DVec3;

/// The face names in storage order.
pub const FACE_NAMES: [&str; 6] = ["+X", "-X", "+Y", "-Y", "+Z", "-Z"];

/// The unit direction of face point (a, b), a and b in [-1, 1].
#[inline]
pub fn face_direction(face: usize, a: f64, b: f64) -> DVec3 {
    let v = DVec3::new(a, b, 1.0);
    orient(face, v / v.length())
}

/// Face `face`'s axes applied to `u = (a, b, 1) * k` (any scale k): the world vector
/// `k * (the table's direction)`. `face_direction` is `orient` of the normalised `(a, b, 1)`, so
/// a table of one face's unit vectors serves all six.
#[inline]
pub fn orient(face: usize, u: DVec3) -> DVec3 {
    match face {
        0 => DVec3::new(u.z, -u.y, -u.x),
        1 => DVec3::new(-u.z, -u.y, u.x),
        2 => DVec3::new(u.x, u.z, u.y),
        3 => DVec3::new(u.x, -u.z, -u.y),
        4 => DVec3::new(u.x, -u.y, u.z),
        _ => DVec3::new(-u.x, -u.y, -u.z),
    }
}

/// The face and face coordinates (a, b) in [-1, 1] of a direction (need not be normalised; a
/// zero or non-finite vector gives the centre of +X). Ties between faces go to the first in
/// storage order of the largest component (x, then y, then z).
#[inline]
pub fn direction_to_face(d: DVec3) -> (usize, f64, f64) {
    let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
    if !(ax.max(ay).max(az) > 0.0) || !d.is_finite() {
        return (0, 0.0, 0.0);
    }
    let (face, a, b, m) = if ax >= ay && ax >= az {
        if d.x > 0.0 {
            (0, -d.z, -d.y, ax)
        } else {
            (1, d.z, -d.y, ax)
        }
    } else if ay >= az {
        if d.y > 0.0 {
            (2, d.x, d.z, ay)
        } else {
            (3, d.x, -d.z, ay)
        }
    } else if d.z > 0.0 {
        (4, d.x, -d.y, az)
    } else {
        (5, -d.x, -d.y, az)
    };
    (face, (a / m).clamp(-1.0, 1.0), (b / m).clamp(-1.0, 1.0))
}

/// Face coordinate of texel edge `i` (0..=size) of an S-texel face: `2 i / S - 1`.
#[inline]
pub fn edge(i: usize, size: usize) -> f64 {
    2.0 * i as f64 / size as f64 - 1.0
}

/// Face coordinate of texel centre `i`: `2 (i + 0.5) / S - 1`.
#[inline]
pub fn centre(i: usize, size: usize) -> f64 {
    (2.0 * i as f64 + 1.0) / size as f64 - 1.0
}

/// The texel (face, x, y) containing a direction; always in range.
#[inline]
pub fn texel_of_direction(d: DVec3, size: usize) -> (usize, usize, usize) {
    let (face, a, b) = direction_to_face(d);
    let s = size as f64;
    let x = (((a + 1.0) * 0.5 * s).floor() as isize).clamp(0, size as isize - 1) as usize;
    let y = (((b + 1.0) * 0.5 * s).floor() as isize).clamp(0, size as isize - 1) as usize;
    (face, x, y)
}

/// The flat index `(face * S + y) * S + x` of the texel containing a direction.
#[inline]
pub fn texel_index_of_direction(d: DVec3, size: usize) -> usize {
    let (f, x, y) = texel_of_direction(d, size);
    (f * size + y) * size + x
}

/// The texel a seamless lookup reads at (x, y) of face `face`, where x and y may be one texel
/// beyond the face (-1 or `size`): the face's own texel inside it, else the texel containing the
/// direction of that position's centre in the face's plane (on a neighbouring face).
pub fn seamless_texel_index(face: usize, x: i64, y: i64, size: usize) -> usize {
    let si = size as i64;
    if (0..si).contains(&x) && (0..si).contains(&y) {
        (face * size + y as usize) * size + x as usize
    } else {
        let ca = (2 * x + 1) as f64 / size as f64 - 1.0;
        let cb = (2 * y + 1) as f64 / size as f64 - 1.0;
        texel_index_of_direction(face_direction(face, ca, cb), size)
    }
}

/// Unit direction of texel (face, x, y)'s centre.
#[inline]
pub fn texel_direction(face: usize, x: usize, y: usize, size: usize) -> DVec3 {
    face_direction(face, centre(x, size), centre(y, size))
}

/// `F(a, b) = atan(a b / sqrt(1 + a^2 + b^2))`: the solid angle of the face rectangle
/// [0, a] x [0, b] (signed).
#[inline]
fn area_element(a: f64, b: f64) -> f64 {
    (a * b).atan2((1.0 + a * a + b * b).sqrt())
}

/// The exact solid angle of the face rectangle [a0, a1] x [b0, b1].
#[inline]
pub fn rect_solid_angle(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    area_element(a1, b1) - area_element(a0, b1) - area_element(a1, b0) + area_element(a0, b0)
}

/// The exact solid angle of texel (x, y) of an S x S face (the same on every face).
#[inline]
pub fn texel_solid_angle(x: usize, y: usize, size: usize) -> f64 {
    rect_solid_angle(edge(x, size), edge(x + 1, size), edge(y, size), edge(y + 1, size))
}

/// The solid angles of one face's texels, row by row (every face has the same).
pub fn face_solid_angles(size: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(size * size);
    for y in 0..size {
        for x in 0..size {
            out.push(texel_solid_angle(x, y, size));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn faces_follow_the_opengl_table() {
        let majors = [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z];
        for (f, m) in majors.iter().enumerate() {
            assert!((face_direction(f, 0.0, 0.0) - *m).length() < 1e-15);
            assert_eq!(direction_to_face(*m).0, f);
        }
        // +Z face, top row (b = -1) looks up; -Z is the lat-long centre (forward).
        assert!(face_direction(4, 0.0, -1.0).y > 0.7);
        let fwd = crate::geometry::latlong::texel_direction(64, 32, 128, 64);
        assert_eq!(direction_to_face(DVec3::from(fwd)).0, 5);
    }

    #[test]
    fn texel_round_trip() {
        for size in [1, 2, 5, 16] {
            for f in 0..6 {
                for y in 0..size {
                    for x in 0..size {
                        assert_eq!(texel_of_direction(texel_direction(f, x, y, size), size), (f, x, y));
                    }
                }
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        for size in [1, 3, 64] {
            let total: f64 = face_solid_angles(size).iter().sum::<f64>() * 6.0;
            assert!((total - 4.0 * PI).abs() < 1e-12, "{size}: {total}");
        }
    }
}
