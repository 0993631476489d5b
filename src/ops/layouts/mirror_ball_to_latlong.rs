//! `MirrorBallToLatLong(image, yaw: 0, pitch: 0, roll: 0, look, ball_fraction: 1, width: 1024,
//! height: 512)`: a chrome-ball photograph to a lat-long map, and where the ball saw it.
//!
//! The image is the ball cropped to its silhouette (the disc inscribed in the square image),
//! photographed orthographically by a camera looking along `R_y(yaw) R_x(pitch) (-Z)` (default
//! -Z, forward; `look` gives that direction instead), screen right `R X`, up `R Y`, with
//! `R = R_y(yaw) R_x(pitch) R_z(roll)`. At disc point (u, v) the normal in the camera's frame
//! is `n = (u, v, sqrt(1 - u^2 - v^2))` and the ball reflects `r = 2 (n.c) n - c`, `c` towards
//! the camera (`geometry::azimuthal`): the ball's centre shows what is behind the camera, its
//! rim the direction `-c` straight behind the ball, where the layout degenerates.
//!
//! Each lat-long texel is a bilinear lookup at its centre direction's disc point, using only
//! pixels whose centres lie within `ball_fraction` of the disc's radius (the rim of a real ball
//! is blurred, stretched and shows its mount: `ball_fraction` < 1 masks it). Port `mask`: 1
//! where the texel's direction falls within that radius (`d.c >= 1 - 2 ball_fraction^2`) and a
//! usable pixel was found, else 0 (the image is 0 there). A non-square image is an error (before
//! the run when its size is known).

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::resample::disc_image::disc_to_latlong;
use crate::values::ty::*;
use crate::values::Image;

use super::{ball_map, ball_params, check_square, require_square};

ball_params! {
    MirrorBallParams {
        /// the mirror-ball photograph, cropped to the ball (square)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
    }
    {
        /// the usable fraction of the ball's radius, in (0, 1]; pixels beyond it are not used
        #[range(0.0, 1.0)]
        pub ball_fraction: f64 = 1.0,
        /// output width
        #[range(1, 1 << 28)]
        pub width: usize = 1024,
        /// output height
        #[range(1, 1 << 28)]
        pub height: usize = 512,
    }
}

const WHAT: &str = "a mirror-ball";

/// The output ports, declared once: the spec and `eval` name them through these.
const IMAGE: Port<Image> = Port::new("image");
const MASK: Port<Image> = Port::new("mask");

pub fn spec() -> OpSpec {
    Op::new(
        "MirrorBallToLatLong",
        1,
        "A chrome-ball photograph (orthographic, cropped to the ball) to a lat-long map, with the mask of what the ball saw",
        eval,
    )
    .output_like(IMAGE, |p| p.image, "the lat-long map (0 where the mask is 0)")
    .port(MASK, SCALAR_T, "1 where the usable part of the ball saw the texel, else 0")
    .size(|_, p| Some((p.width as u64, p.height as u64)))
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: MirrorBallParams<Check>) -> Result<(), CheckProblem> {
    if p.ball_fraction <= 0.0 {
        return Err(CheckProblem::at(
            MirrorBallParams::ball_fraction,
            "ball_fraction must be in (0, 1]: 0 leaves no usable pixel",
        ));
    }
    ball_map(p.yaw, p.pitch, p.roll, p.look, MirrorBallParams::look)?;
    check_square("image", p.image, WHAT)
}

fn eval(_: &mut OpContext, p: MirrorBallParams) -> Result<Outputs, OpError> {
    let map =
        ball_map(p.yaw, p.pitch, p.roll, p.look, MirrorBallParams::look).map_err(|e| OpError::Invalid(e.message))?;
    require_square(&p.image, "image", WHAT)?;
    let out = disc_to_latlong(&p.image, &map, p.ball_fraction, p.width, p.height);
    Ok(Outputs::new().port(IMAGE, out.image).port(MASK, out.mask))
}
