//! `Rotate(image, yaw, pitch, roll)` or `Rotate(image, matrix: (m00, ..., m22))`: a lat-long map
//! or a cube map rotated on the sphere, energy-preserving.
//!
//! Angles in degrees about hdrflow's world axes, `R = R_y(yaw) R_x(pitch) R_z(roll)`; the matrix
//! is row-major, world to world; the content seen in direction v moves to R v (see
//! `maths::resample::rotation`). A whole-column yaw of a lat-long map is an exact column roll, any
//! other yaw alone the exact blend of two columns (version 3; version 2 integrated it by cut
//! cells, off by up to 1.7e-4 in the pole rows); any other rotation averages the rotated map over
//! each output texel's footprint (version 4: by cut cells to a tolerance of 4e-9 of the map's
//! magnitude instead of 1e-9, the same accuracy against a brute force on the tests' noise map).

use crate::engine::fields::{AnyValue, Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::rotation::Rotation;
use crate::maths::resample::layouts::{to_cube, CubeSource};
use crate::maths::resample::rotation::{roll_columns, rotate_latlong, Rotated};
use crate::ops::latlong_input::warn_unless_latlong_size;
use crate::values::ty::*;
use crate::values::{Cubemap, Image};

crate::params! {
    pub struct RotateParams {
        /// the lat-long map (any channels) or cube map to rotate
        #[input(&[IMAGE_T, SCALAR_T, CUBEMAP_T])]
        pub image: Input<AnyValue>,
        /// degrees about +Y (up); positive turns forward (-Z) towards left (-X)
        #[range(-3600.0, 3600.0)]
        pub yaw: f64 = 0.0,
        /// degrees about +X (right); positive turns forward towards up
        #[range(-3600.0, 3600.0)]
        pub pitch: f64 = 0.0,
        /// degrees about +Z (back); positive turns right (+X) towards up
        #[range(-3600.0, 3600.0)]
        pub roll: f64 = 0.0,
        /// instead of the angles: a rotation matrix, row-major, world to world (orthonormal to 1e-6, determinant +1)
        pub matrix: Option<[f64; 9]>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Rotate", 4, "Rotate a lat-long or cube map on the sphere (energy-preserving)", eval)
        .output_like("image", |p| p.image, "the rotated map")
        .size(|_, p| p.image.size)
        .check(check)
        .into()
}

impl<S: crate::engine::fields::Stage> RotateParams<S> {
    fn rotation(&self) -> Result<Rotation, CheckProblem> {
        match self.matrix {
            None => Ok(Rotation::from_yaw_pitch_roll(self.yaw, self.pitch, self.roll)),
            Some(_) if [self.yaw, self.pitch, self.roll] != [0.0; 3] => {
                Err(CheckProblem::at(RotateParams::matrix, "give either yaw/pitch/roll or a matrix, not both"))
            }
            Some(m) => Rotation::from_row_major(m).map_err(|e| CheckProblem::at(RotateParams::matrix, e)),
        }
    }
}

fn check(_: &CheckContext, p: RotateParams<Check>) -> Result<(), CheckProblem> {
    p.rotation().map(|_| ())
}

fn eval(ctx: &mut OpContext, p: RotateParams) -> Result<Value, OpError> {
    let r = p.rotation().map_err(|e| OpError::Invalid(e.message))?;
    if p.matrix.is_none() && [p.yaw, p.pitch, p.roll] == [0.0; 3] {
        if let Some(img) = p.image.value().get::<Image>() {
            warn_unless_latlong_size(ctx, RotateParams::image, img.width, img.height);
        }
        // No turn: the map itself (a bake's `turned` node without --yaw).
        return Ok(p.image.into_value());
    }
    let v = p.image.value();
    if let Some(img) = v.get::<Image>() {
        warn_unless_latlong_size(ctx, RotateParams::image, img.width, img.height);
        if let Some(k) = r.whole_column_shift(img.width) {
            // An exact roll of whole columns, in place when no other node reads the map.
            let mut img = p.image.into_value().take::<Image>().expect("the value is an image");
            roll_columns(&mut img, k);
            return Ok(Value::new(img));
        }
        return Ok(Value::new(rotate_latlong(img, r)));
    }
    if let Some(cube) = v.get::<Cubemap>() {
        return Ok(Value::new(to_cube(&Rotated::new(&CubeSource::new(cube), r), cube.size)));
    }
    Err(OpError::Invalid(format!("Rotate takes a lat-long image or a cube map, not a {}", v.value_type())))
}
