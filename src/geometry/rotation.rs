//! Rotations of the sphere of directions, in hdrflow's world axes (+Y up, -Z forward, +X right;
//! see `geometry::latlong`), kept as matrices. Rotating a map by one is
//! [`crate::maths::resample::rotation`].
//!
//! Angles, in degrees, follow the right-hand rule about world axes and compose as
//! `R = R_y(yaw) * R_x(pitch) * R_z(roll)` (roll first, then pitch, then yaw):
//!
//! - `yaw` about +Y: a positive yaw turns -Z (forward) towards -X (left), `R_y(90) (-Z) = -X`;
//! - `pitch` about +X: a positive pitch turns -Z up, `R_x(90) (-Z) = +Y`;
//! - `roll` about +Z: a positive roll turns +X towards +Y.

use glam::{DMat3, DVec3};

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

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn whole_column_yaws_are_found() {
        assert_eq!(Rotation::from_yaw_pitch_roll(90.0, 0.0, 0.0).whole_column_shift(64), Some(16));
        assert_eq!(Rotation::from_yaw_pitch_roll(-90.0, 0.0, 0.0).whole_column_shift(64), Some(48));
        assert_eq!(Rotation::from_yaw_pitch_roll(1.0, 0.0, 0.0).whole_column_shift(64), None);
        assert_eq!(Rotation::from_yaw_pitch_roll(90.0, 1.0, 0.0).whole_column_shift(64), None);
        assert_eq!(Rotation::IDENTITY.whole_column_shift(64), Some(0));
    }
}
