//! `LatLongToMirrorBall(env, size: 512, yaw: 0, pitch: 0, roll: 0, look)`: the chrome ball a
//! lat-long map would show, photographed orthographically: the inverse of `MirrorBallToLatLong`
//! with the same camera fields (default: the camera looks along -Z, so the ball's centre shows
//! +Z and its rim -Z).
//!
//! The ball fills the `size x size` image (outside the disc 0). The orthographic mirror ball is
//! an equal-area layout (`dOmega = 4 du dv`, `geometry::azimuthal`), so each pixel whose centre
//! is in the disc is the plain area mean of the map over the pixel's part of the disc, computed
//! as the solid-angle mean over its footprint by adaptive subdivision
//! (`maths::resample::disc_image::latlong_to_disc`): a rim pixel, which reflects a band tens of degrees
//! wide around the back direction, averages all of it instead of point-sampling it.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::resample::disc_image::latlong_to_disc;
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Image;

use super::{ball_map, ball_params};

ball_params! {
    LatLongToMirrorBallParams {
        /// the lat-long map (any channels)
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
    }
    {
        /// output width and height (the ball's diameter in pixels)
        #[range(1, 1 << 14)]
        pub size: usize = 512,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LatLongToMirrorBall",
        3,
        "The orthographic chrome-ball image of a lat-long map (footprint-averaged; outside the disc 0)",
        eval,
    )
    .output_like("image", |p| p.env, "the size x size mirror-ball image")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: LatLongToMirrorBallParams<Check>) -> Result<(), CheckProblem> {
    ball_map(p.yaw, p.pitch, p.roll, p.look, LatLongToMirrorBallParams::look).map(|_| ())
}

fn eval(ctx: &mut OpContext, p: LatLongToMirrorBallParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let map = ball_map(p.yaw, p.pitch, p.roll, p.look, LatLongToMirrorBallParams::look)
        .map_err(|e| OpError::Invalid(e.message))?;
    Ok(Value::new(latlong_to_disc(&p.env, &map, p.size)))
}
