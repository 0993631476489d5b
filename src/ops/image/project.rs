//! `Project(env, width: 512, height: 512, fov: 90, yaw, pitch, roll, model: Perspective,
//! filter: Bilinear)`: a camera view of a lat-long map, as datasets cut their input crops.
//!
//! The lens (`geometry::lens`): pixel (i, j)'s centre is the plane point
//! `u = (i + 0.5) / W * 2 - 1`, `v = 1 - (j + 0.5) / H * 2`, `(x, y) = (u, v H / W)`; `fov`
//! is the horizontal field of view in degrees; `Perspective` (fov in (0, 180)), `Fisheye`
//! (equidistant, `theta = r fov / 2`, fov in (0, 360], black outside the circle r = 1) or
//! `Orthographic` (the front hemisphere, `sin(fov / 2)` the half-width, fov in (0, 180]). At
//! yaw = pitch = roll = 0 the view looks at the map's centre, -Z, +Y up, +X right; the angles
//! are `Rotate`'s (`R = R_y(yaw) R_x(pitch) R_z(roll)`) and each ray is `R` times the camera
//! ray, so `Project(Rotate(env, R))` equals `Project(env)` turned by `R^T`. `filter` is
//! `Bilinear` (a lookup along the pixel's centre ray) or `Area` (the solid-angle mean over the
//! pixel's footprint, `maths::camera::view`). A fov outside its model's range is a pipeline
//! error at `fov` before anything runs.
//!
//! Port `camera` (version 2) is the view's camera (`values::Camera`: model, fov, size, angles and
//! the world-to-camera matrix `R^T`), for `CropLabel`, so that a crop's label is built from the
//! fields that cut the crop and cannot drift from them.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::geometry::lens::{fov_problem, Lens, Model};
use crate::maths::camera::view::{project, Filter};
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::{Camera, Image};

crate::params! {
    pub struct ProjectParams {
        /// the lat-long map (any channels)
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
        /// the view's width in pixels
        #[range(1, 1 << 28)]
        pub width: usize = 512,
        /// the view's height in pixels
        #[range(1, 1 << 28)]
        pub height: usize = 512,
        /// horizontal field of view, degrees: Perspective (0, 180), Fisheye (0, 360], Orthographic (0, 180]
        pub fov: f64 = 90.0,
        /// degrees about +Y (up), as in Rotate; positive looks left (towards -X)
        #[range(-3600.0, 3600.0)]
        pub yaw: f64 = 0.0,
        /// degrees about +X (right), as in Rotate; positive looks up
        #[range(-3600.0, 3600.0)]
        pub pitch: f64 = 0.0,
        /// degrees about +Z (back), as in Rotate; positive turns the image's right towards up
        #[range(-3600.0, 3600.0)]
        pub roll: f64 = 0.0,
        /// Perspective, Fisheye (equidistant) or Orthographic
        pub model: Model = Model::Perspective,
        /// Bilinear (lookup at the pixel centre) or Area (solid-angle mean over the pixel's footprint)
        pub filter: Filter = Filter::Bilinear,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const IMAGE: Port<Image> = Port::new("image");
const CAMERA: Port<Camera> = Port::new("camera");

pub fn spec() -> OpSpec {
    Op::new("Project", 2, "A perspective, fisheye or orthographic camera view of a lat-long map", eval)
        .output_like(IMAGE, |p| p.env, "the view, width x height, env's channels")
        .port(CAMERA, CAMERA_T, "the view's camera (model, fov, size, angles, world-to-camera matrix)")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .check(check)
        .into()
}

fn check(_: &CheckContext, p: ProjectParams<Check>) -> Result<(), CheckProblem> {
    fov_problem(p.model, p.fov).map_or(Ok(()), |e| Err(CheckProblem::at(ProjectParams::fov, e)))
}

fn eval(ctx: &mut OpContext, p: ProjectParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let lens = Lens::new(p.model, p.fov, p.width, p.height).map_err(OpError::Invalid)?;
    let camera = Camera {
        model: p.model,
        fov: p.fov,
        width: p.width,
        height: p.height,
        yaw: p.yaw,
        pitch: p.pitch,
        roll: p.roll,
    };
    let view = project(&p.env, &lens, camera.rotation(), p.filter);
    Ok(Outputs::new().port(IMAGE, view).port(CAMERA, camera))
}
