//! `Camera`: the camera of a view cut out of an environment map, as `Project` declares it (its
//! lens and its rotation), so that what is written about a crop cannot drift from the crop.

use glam::DVec3;

use crate::maths::camera::Model;
use crate::maths::rotation::Rotation;

/// A `width x height` view through a lens of `model` and horizontal field of view `fov`
/// (degrees), turned by `yaw`, `pitch`, `roll` (degrees, `Rotate`'s angles:
/// `R = R_y(yaw) R_x(pitch) R_z(roll)`). Camera space looks down -Z with +Y up and +X right, and
/// the view sees world direction `R c` for camera ray `c` (`maths::camera`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub model: Model,
    pub fov: f64,
    pub width: usize,
    pub height: usize,
    pub yaw: f64,
    pub pitch: f64,
    pub roll: f64,
}

impl Camera {
    /// `R`, camera to world: the rotation `Project` turns every camera ray by.
    pub fn rotation(&self) -> Rotation {
        Rotation::from_yaw_pitch_roll(self.yaw, self.pitch, self.roll)
    }

    /// `R^T`, world to camera, row-major (`[row][column]`): it maps a world direction `d` to
    /// the camera-space direction `R^T d`, so the view's centre ray goes to (0, 0, -1) and a
    /// light's world direction to where the camera sees it.
    pub fn world_to_camera(&self) -> [[f64; 3]; 3] {
        // Row i of R^T is column i of R.
        let m = self.rotation().0;
        [m.x_axis, m.y_axis, m.z_axis].map(|c| c.to_array())
    }

    /// The world direction the view's centre looks along, `R (0, 0, -1)`.
    pub fn forward(&self) -> DVec3 {
        self.rotation().apply(DVec3::NEG_Z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(m: [[f64; 3]; 3], d: DVec3) -> DVec3 {
        let [r0, r1, r2] = m.map(DVec3::from_array);
        DVec3::new(r0.dot(d), r1.dot(d), r2.dot(d))
    }

    #[test]
    fn world_to_camera_undoes_the_view_rotation() {
        let cams = [(0.0, 0.0, 0.0), (90.0, 0.0, 0.0), (30.0, 10.0, 0.0), (-123.0, 45.0, 17.0), (200.0, -80.0, -60.0)];
        for (yaw, pitch, roll) in cams {
            let cam = Camera { model: Model::Perspective, fov: 60.0, width: 8, height: 6, yaw, pitch, roll };
            let m = cam.world_to_camera();
            // The centre ray, and the camera's right and up, come back to the camera axes.
            assert!((apply(m, cam.forward()) - DVec3::NEG_Z).length() < 1e-12, "{yaw} {pitch} {roll}");
            let r = cam.rotation();
            assert!((apply(m, r.apply(DVec3::X)) - DVec3::X).length() < 1e-12);
            assert!((apply(m, r.apply(DVec3::Y)) - DVec3::Y).length() < 1e-12);
        }
        // Yaw 90 looks left (-X): the world's -X is straight ahead of that camera.
        let left =
            Camera { model: Model::Perspective, fov: 60.0, width: 8, height: 6, yaw: 90.0, pitch: 0.0, roll: 0.0 };
        assert!((left.forward() - DVec3::NEG_X).length() < 1e-12);
        assert!((apply(left.world_to_camera(), DVec3::NEG_X) - DVec3::NEG_Z).length() < 1e-12);
    }
}
