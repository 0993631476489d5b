//! `MergeMirrorBalls(a, b, view_a, view_b, ball_fraction: 1, camera_cone_deg: 20, width)`: one
//! lat-long map from two
//! photographs of a mirror ball taken from two viewpoints (commonly 90 degrees apart), each
//! direction from the ball that sees it at the smaller incidence angle (farther from its rim),
//! blended across the seam, so that the stretched rim and the blind spot behind each ball are
//! replaced by the other ball's view (`maths::capture::two_balls`: formulas and error bound).
//!
//! `a`, `b`: square crops of the ball, as `MirrorBallToLatLong` takes them; `view_a`, `view_b`:
//! each camera's `(yaw, pitch)` in degrees, as `MirrorBallToLatLong(yaw, pitch)` (the camera
//! looks along `R_y(yaw) R_x(pitch) (-Z)`); `ball_fraction`: the fraction of the crop's side the
//! ball's diameter covers (1: the ball touches the crop's edges). The map is `width x width / 2`,
//! by default twice the larger ball's diameter in pixels. Port `mask`: 1 where neither ball sees
//! the direction usably (incidence over 80 degrees on both; the map is 0 there), else 0. Each
//! ball's centre shows its camera and the photographer: the directions within `camera_cone_deg`
//! of a camera are taken from the other ball (0 keeps them).

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::capture::two_balls::{merge_balls, view_map, Ball};
use crate::ops::layouts::{check_square, require_square};
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct MergeMirrorBallsParams {
        /// the first mirror-ball photograph, cropped to the ball (square)
        #[input(ANY_IMAGE)]
        pub a: Input<Image>,
        /// the second mirror-ball photograph, from another viewpoint (square, a's channels)
        #[input(ANY_IMAGE)]
        pub b: Input<Image>,
        /// (yaw, pitch) in degrees of the camera that took a, as MirrorBallToLatLong's yaw and pitch
        #[range(-3600.0, 3600.0)]
        pub view_a: [f64; 2],
        /// (yaw, pitch) in degrees of the camera that took b
        #[range(-3600.0, 3600.0)]
        pub view_b: [f64; 2],
        /// the fraction of the crop's side the ball's diameter covers, in (0, 1]
        #[range(0.0, 1.0)]
        pub ball_fraction: f64 = 1.0,
        /// directions within this many degrees of a camera (its own reflection, and the
        /// photographer's) come from the other ball; 0 keeps them
        #[range(0.0, 90.0)]
        pub camera_cone_deg: f64 = 20.0,
        /// output width (height = width / 2); default twice the larger ball's diameter in pixels
        #[range(2, 1 << 16)]
        pub width: Option<usize>,
    }
}

const WHAT: &str = "a mirror-ball";

const IMAGE: Port<Image> = Port::new("image");
const MASK: Port<Image> = Port::new("mask");

pub fn spec() -> OpSpec {
    Op::new(
        "MergeMirrorBalls",
        2,
        "Two mirror-ball photographs from two viewpoints to one lat-long map, each direction from the ball that sees it farther from its rim",
        eval,
    )
    .output_like(IMAGE, |p| p.a, "the lat-long map (0 where the mask is 1)")
    .port(MASK, SCALAR_T, "1 where neither ball sees the direction usably, else 0")
    .size(|_, p| {
        let side = match (p.a.size, p.b.size) {
            (Some((a, _)), Some((b, _))) => a.max(b),
            (Some((a, _)), None) => a,
            (None, Some((b, _))) => b,
            (None, None) => return p.width.map(|w| (w as u64, (w / 2) as u64)),
        };
        let (w, h) = map_size(p.width, side as usize, p.ball_fraction);
        Some((w as u64, h as u64))
    })
    .check(check)
    .into()
}

/// The output size: `width` or twice the ball's diameter `fraction * side` (at least 2), by half.
fn map_size(width: Option<usize>, side: usize, fraction: f64) -> (usize, usize) {
    let w = width.unwrap_or_else(|| ((2.0 * fraction * side as f64).round() as usize).max(2));
    (w, (w / 2).max(1))
}

fn check(_: &CheckContext, p: MergeMirrorBallsParams<Check>) -> Result<(), CheckProblem> {
    if !(p.ball_fraction > 0.0) {
        return Err(CheckProblem::at(
            MergeMirrorBallsParams::ball_fraction,
            format!(
                "ball_fraction must be in (0, 1], not {}: it is the ball's diameter over the crop's side",
                p.ball_fraction
            ),
        ));
    }
    check_square("a", p.a, WHAT)?;
    check_square("b", p.b, WHAT)
}

fn eval(_: &mut OpContext, p: MergeMirrorBallsParams) -> Result<Outputs, OpError> {
    require_square(&p.a, "a", WHAT)?;
    require_square(&p.b, "b", WHAT)?;
    if p.a.channels != p.b.channels {
        return Err(OpError::Invalid(format!(
            "\"a\" has {} channels and \"b\" {}: the two photographs must have the same channels",
            p.a.channels, p.b.channels
        )));
    }
    let (width, height) = map_size(p.width, p.a.width.max(p.b.width), p.ball_fraction);
    let a = Ball { image: &p.a, map: view_map(p.view_a[0], p.view_a[1]), fraction: p.ball_fraction };
    let b = Ball { image: &p.b, map: view_map(p.view_b[0], p.view_b[1]), fraction: p.ball_fraction };
    let merged = merge_balls(&a, &b, width, height, p.camera_cone_deg);
    Ok(Outputs::new().port(IMAGE, merged.image).port(MASK, merged.unseen))
}
