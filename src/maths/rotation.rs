//! Rotations of the sphere of directions, in hdrflow's world axes (+Y up, -Z forward, +X right;
//! see `geometry::latlong`), and a rotated view of any spherical map.
//!
//! Angles, in degrees, follow the right-hand rule about world axes and compose as
//! `R = R_y(yaw) * R_x(pitch) * R_z(roll)` (roll first, then pitch, then yaw):
//!
//! - `yaw` about +Y: a positive yaw turns -Z (forward) towards -X (left), `R_y(90) (-Z) = -X`;
//! - `pitch` about +X: a positive pitch turns -Z up, `R_x(90) (-Z) = +Y`;
//! - `roll` about +Z: a positive roll turns +X towards +Y.
//!
//! Rotating a map by R moves the content seen in direction `v` to direction `R v`:
//! `out(d) = in(R^T d)`. On a lat-long map, `R_y(a)` maps azimuth phi to phi - a, so a yaw of
//! `k * 360 / W` degrees is a roll of the columns by k: `out[x] = in[(x + k) mod W]`.

use glam::{DMat3, DVec3};

use crate::maths::resample::{per_channel_triples, to_latlong_precise, SphereSource};
use crate::values::Image;

/// A rotation of the sphere, kept as its matrix (world to world, orthonormal, det +1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotation(pub DMat3);

/// How far a matrix may be from orthonormal (each entry of `M^T M - I`), and its determinant
/// from 1: tighter than any hand-typed matrix of six decimals needs, looser than rounding.
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-6;

impl Rotation {
    pub const IDENTITY: Rotation = Rotation(DMat3::IDENTITY);

    /// `R_y(yaw) R_x(pitch) R_z(roll)`, angles in degrees (see the module documentation).
    pub fn from_yaw_pitch_roll(yaw: f64, pitch: f64, roll: f64) -> Rotation {
        Rotation(
            DMat3::from_rotation_y(yaw.to_radians())
                * DMat3::from_rotation_x(pitch.to_radians())
                * DMat3::from_rotation_z(roll.to_radians()),
        )
    }

    /// From a row-major 3x3 matrix, checked to be a rotation (orthonormal to
    /// [`ORTHONORMAL_TOLERANCE`], determinant +1: a mirror is refused, it would flip the map).
    pub fn from_row_major(m: [f64; 9]) -> Result<Rotation, String> {
        if m.iter().any(|v| !v.is_finite()) {
            return Err("the matrix has a NaN or infinite entry".into());
        }
        let mat = DMat3::from_cols_array(&m).transpose();
        let gram = mat.transpose() * mat;
        let worst = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| (gram.col(j)[i] - if i == j { 1.0 } else { 0.0 }).abs())
            .fold(0.0f64, f64::max);
        if worst > ORTHONORMAL_TOLERANCE {
            return Err(format!(
                "the matrix is not orthonormal (M^T M differs from the identity by {worst:.3e}, more than {ORTHONORMAL_TOLERANCE:e})"
            ));
        }
        let det = mat.determinant();
        if (det - 1.0).abs() > ORTHONORMAL_TOLERANCE {
            return Err(format!("the matrix has determinant {det:.6}: a mirror, not a rotation"));
        }
        Ok(Rotation(mat))
    }

    pub fn apply(&self, d: DVec3) -> DVec3 {
        self.0 * d
    }

    pub fn inverse(&self) -> Rotation {
        Rotation(self.0.transpose())
    }

    /// The yaw in degrees if this is a rotation about +Y alone (to 1e-12 per entry).
    pub fn pure_yaw_degrees(&self) -> Option<f64> {
        let m = self.0;
        let about_y = (m.y_axis - DVec3::Y).abs().max_element() < 1e-12
            && m.x_axis.y.abs() < 1e-12
            && m.z_axis.y.abs() < 1e-12
            && (m.x_axis.x - m.z_axis.z).abs() < 1e-12
            && (m.x_axis.z + m.z_axis.x).abs() < 1e-12;
        // R_y(a) has x_axis = (cos a, 0, -sin a).
        about_y.then(|| (-m.x_axis.z).atan2(m.x_axis.x).to_degrees())
    }

    /// The number of whole columns a pure yaw moves a lat-long map of width `width` by, when it
    /// is one (to 1e-9 of a column): `k = yaw * W / 360`, taken mod W.
    pub fn whole_column_shift(&self, width: usize) -> Option<usize> {
        let columns = self.pure_yaw_degrees()? * width as f64 / 360.0;
        let k = columns.round();
        ((columns - k).abs() < 1e-9).then(|| k.rem_euclid(width as f64) as usize % width.max(1))
    }
}

/// A spherical map seen rotated: `texel_of(d)` is the source's texel at `R^T d`.
pub struct Rotated<'a, S: SphereSource> {
    pub source: &'a S,
    /// `R^T`, the inverse rotation, applied to every output direction.
    inverse: DMat3,
}

impl<'a, S: SphereSource> Rotated<'a, S> {
    pub fn new(source: &'a S, rotation: Rotation) -> Self {
        Rotated { source, inverse: rotation.0.transpose() }
    }
}

impl<S: SphereSource> SphereSource for Rotated<'_, S> {
    fn texel_of(&self, d: DVec3) -> usize {
        self.source.texel_of(self.inverse * d)
    }
    fn rgb(&self, t: usize) -> [f64; 3] {
        self.source.rgb(t)
    }
    fn texel_angle(&self) -> f64 {
        self.source.texel_angle()
    }
    fn magnitude(&self) -> f64 {
        self.source.magnitude()
    }
}

/// Rolls every row of a lat-long image left by `k` columns, in place: the exact rotation by a
/// yaw of `k` whole columns (`Rotation::whole_column_shift`), column x taking column x + k.
pub fn roll_columns(img: &mut Image, k: usize) {
    let row_len = img.width * img.channels;
    for row in img.data.chunks_exact_mut(row_len.max(1)) {
        row.rotate_left(k * img.channels);
    }
}

/// A lat-long map rotated by `r`, every channel alike, keeping its size and channel names.
///
/// A whole-column yaw is an exact roll of the columns (the same bits). Any other rotation gives
/// each output texel the solid-angle mean of the rotated map over its footprint
/// (`resample::to_latlong_precise`, leaves to 1e-9 of the map's magnitude), which keeps the sphere integral
/// (tested: 1e-4 relative).
pub fn rotate_latlong(img: &Image, r: Rotation) -> Image {
    let (w, h) = (img.width, img.height);
    if let Some(k) = r.whole_column_shift(w) {
        let mut out = img.clone();
        roll_columns(&mut out, k);
        return out;
    }
    per_channel_triples(img, w, h, |src| to_latlong_precise(&Rotated::new(src, r), w, h, 1e-9, 12))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).abs().max_element() < 1e-12
    }

    #[test]
    fn the_angles_turn_the_axes_as_documented() {
        let fwd = DVec3::NEG_Z;
        assert!(close(Rotation::from_yaw_pitch_roll(90.0, 0.0, 0.0).apply(fwd), DVec3::NEG_X));
        assert!(close(Rotation::from_yaw_pitch_roll(0.0, 90.0, 0.0).apply(fwd), DVec3::Y));
        assert!(close(Rotation::from_yaw_pitch_roll(0.0, 0.0, 90.0).apply(DVec3::X), DVec3::Y));
        // Roll first, then pitch, then yaw.
        let r = Rotation::from_yaw_pitch_roll(90.0, 90.0, 0.0);
        assert!(close(r.apply(fwd), DVec3::Y));
        assert!(close(r.apply(DVec3::X), DVec3::NEG_Z));
    }

    #[test]
    fn matrices_are_checked() {
        let r = Rotation::from_yaw_pitch_roll(30.0, -20.0, 10.0);
        let m = r.0.transpose().to_cols_array(); // row-major
        assert_eq!(Rotation::from_row_major(m).unwrap(), r);
        let mut skew = m;
        skew[1] += 1e-4;
        assert!(Rotation::from_row_major(skew).unwrap_err().contains("not orthonormal"));
        let mirror = [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert!(Rotation::from_row_major(mirror).unwrap_err().contains("mirror"));
        assert!(Rotation::from_row_major([f64::NAN; 9]).unwrap_err().contains("NaN"));
    }

    fn test_map(w: usize, h: usize, c: usize) -> Image {
        let data = (0..w * h * c).map(|i| ((i * 7919) % 101) as f32 * 0.01 + (i % c) as f32).collect();
        Image::from_vec(w, h, c, data)
    }

    fn integral(img: &Image) -> Vec<f64> {
        let (w, h, c) = (img.width, img.height, img.channels);
        let mut sum = vec![0.0; c];
        for y in 0..h {
            for x in 0..w {
                for (k, s) in sum.iter_mut().enumerate() {
                    *s += img.pixel(x, y)[k] as f64 * latlong::texel_solid_angle(y, w, h);
                }
            }
        }
        sum
    }

    #[test]
    fn a_whole_column_yaw_rolls_the_columns_exactly() {
        let img = test_map(32, 16, 4);
        let out = rotate_latlong(&img, Rotation::from_yaw_pitch_roll(45.0, 0.0, 0.0));
        for y in 0..16 {
            for x in 0..32 {
                assert_eq!(out.pixel(x, y), img.pixel((x + 4) % 32, y));
            }
        }
        // The resampled path agrees with the roll on a map that is constant per texel.
        let general = rotate_latlong(&img, Rotation::from_yaw_pitch_roll(45.0 + 1e-7, 0.0, 0.0));
        let worst = general.data.iter().zip(&out.data).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
    }

    #[test]
    fn rotations_keep_the_integral_and_invert() {
        let img = test_map(64, 32, 3);
        let r = Rotation::from_yaw_pitch_roll(33.0, 21.0, -12.0);
        let out = rotate_latlong(&img, r);
        for (a, b) in integral(&out).iter().zip(integral(&img)) {
            assert!(((a - b) / b).abs() < 1e-4, "{a} vs {b}");
        }
        let back = rotate_latlong(&out, r.inverse());
        // Two resamplings blur a texel-noise map; the mean error stays a fraction of its range.
        let mean_err: f64 =
            back.data.iter().zip(&img.data).map(|(a, b)| (a - b).abs() as f64).sum::<f64>() / img.data.len() as f64;
        assert!(mean_err < 0.25, "{mean_err}");
    }

    #[test]
    fn a_point_light_moves_where_the_rotation_sends_it() {
        let (w, h) = (128, 64);
        let mut img = Image::new(w, h, 1);
        let (x0, y0) = (96, 20);
        img.data[y0 * w + x0] = 1.0;
        let r = Rotation::from_yaw_pitch_roll(17.0, 25.0, 5.0);
        let out = rotate_latlong(&img, r);
        let (mut best, mut at) = (0.0, (0, 0));
        for y in 0..h {
            for x in 0..w {
                if out.data[y * w + x] > best {
                    best = out.data[y * w + x];
                    at = (x, y);
                }
            }
        }
        let want = r.apply(DVec3::from(latlong::texel_direction(x0, y0, w, h)));
        let got = DVec3::from(latlong::texel_direction(at.0, at.1, w, h));
        assert!(want.angle_between(got) < 2.0 * std::f64::consts::PI / w as f64, "{want} vs {got}");
    }

    #[test]
    fn whole_column_yaws_are_found() {
        assert_eq!(Rotation::from_yaw_pitch_roll(90.0, 0.0, 0.0).whole_column_shift(64), Some(16));
        assert_eq!(Rotation::from_yaw_pitch_roll(-90.0, 0.0, 0.0).whole_column_shift(64), Some(48));
        assert_eq!(Rotation::from_yaw_pitch_roll(1.0, 0.0, 0.0).whole_column_shift(64), None);
        assert_eq!(Rotation::from_yaw_pitch_roll(90.0, 1.0, 0.0).whole_column_shift(64), None);
        assert_eq!(Rotation::IDENTITY.whole_column_shift(64), Some(0));
    }
}
