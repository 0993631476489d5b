//! `Label`: what a dataset stores about one camera crop of an environment map, as `CropLabel`
//! gathers it: the crop's camera and, when given, the map's SH coefficients, spherical
//! Gaussian lobes and parametric lights.

use crate::data::{Camera, Lights, ShCoefficients, SphericalGaussians};

/// One crop's label. The lighting parts are in the frame of the map the crop was cut from
/// (hdrflow's world axes); `camera.world_to_camera()` takes a direction into the crop's camera
/// space.
#[derive(Clone, Debug, PartialEq)]
pub struct Label {
    pub camera: Camera,
    pub sh: Option<ShCoefficients>,
    pub sgs: Option<SphericalGaussians>,
    pub lights: Option<Lights>,
}
