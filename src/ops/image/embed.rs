//! `Embed(env, view, fov: 90, yaw, pitch, roll, model: Perspective)`, or `Embed(view, width:
//! 1024, height: 512, ...)`: the inverse of `Project`, a photo pasted into a lat-long map.
//!
//! Each texel of the map whose centre direction `d` the camera sees, `R^T d` having a plane
//! point inside the view's frame (in front of a perspective or orthographic camera, within the
//! fisheye's circle), takes the bilinear lookup of `view` at that point; the others keep `env`.
//! The camera (lens, fov, angles, frame of `view`'s size) is `Project`'s, so `Embed(Project(env))`
//! returns `env` inside the mask to the two lookups' interpolation error. Without `env` the
//! view goes into a black `width` x `height` map (default 1024 x `width / 2`) with `view`'s
//! channels. Port `mask`: one channel `Y`, 1 where the view was pasted, 0 elsewhere.
//! `view` must have `env`'s channel count and kind (both scalar fields or both images).

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::geometry::lens::{fov_problem, Lens, Model};
use crate::geometry::rotation::Rotation;
use crate::maths::camera::view::embed;
use crate::ops::latlong_input::warn_unless_latlong_size;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct EmbedParams {
        /// the lat-long map to paste into; not wired: a black map of width x height
        #[input(ANY_IMAGE)]
        pub env: Option<Input<Image>>,
        /// the photo (any size; the channels of env)
        #[input(ANY_IMAGE)]
        pub view: Input<Image>,
        /// horizontal field of view of the photo, degrees: Perspective (0, 180), Fisheye (0, 360], Orthographic (0, 180]
        pub fov: f64 = 90.0,
        /// degrees about +Y (up), as in Rotate and Project
        #[range(-3600.0, 3600.0)]
        pub yaw: f64 = 0.0,
        /// degrees about +X (right), as in Rotate and Project
        #[range(-3600.0, 3600.0)]
        pub pitch: f64 = 0.0,
        /// degrees about +Z (back), as in Rotate and Project
        #[range(-3600.0, 3600.0)]
        pub roll: f64 = 0.0,
        /// Perspective, Fisheye (equidistant) or Orthographic
        pub model: Model = Model::Perspective,
        /// the blank map's width when env is not wired (default 1024)
        #[range(1, 1 << 28)]
        pub width: Option<usize>,
        /// the blank map's height when env is not wired (default width / 2)
        #[range(1, 1 << 28)]
        pub height: Option<usize>,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const IMAGE: Port<Image> = Port::new("image");
const MASK: Port<Image> = Port::new("mask");

pub fn spec() -> OpSpec {
    Op::new("Embed", 1, "Paste a camera view (perspective, fisheye, orthographic) into a lat-long map", eval)
        .output_computed(
            IMAGE,
            "the type of `env`, else of `view`",
            |_, p| Ok(p.env.unwrap_or(p.view).ty),
            "the map with the view pasted in",
        )
        .port(MASK, SCALAR_T, "1 where the view was pasted, 0 elsewhere")
        .size(|_, p| match p.env {
            Some(env) => env.size,
            None => Some(blank_size(p.width, p.height)),
        })
        .check(check)
        .into()
}

fn blank_size(width: Option<usize>, height: Option<usize>) -> (u64, u64) {
    let w = width.unwrap_or(1024);
    (w as u64, height.unwrap_or((w / 2).max(1)) as u64)
}

fn check(_: &CheckContext, p: EmbedParams<Check>) -> Result<(), CheckProblem> {
    if let Some(e) = fov_problem(p.model, p.fov) {
        return Err(CheckProblem::at(EmbedParams::fov, e));
    }
    let Some(env) = p.env else { return Ok(()) };
    for (field, given) in [("width", p.width.is_some()), ("height", p.height.is_some())] {
        if given {
            return Err(CheckProblem::at(
                field,
                format!("`{field}` sizes a blank map: with `env` wired the map is env"),
            ));
        }
    }
    if env.ty != p.view.ty {
        return Err(CheckProblem::at(
            EmbedParams::view,
            format!("view is a {} but env is a {}: they must be alike", p.view.ty, env.ty),
        ));
    }
    Ok(())
}

fn eval(ctx: &mut OpContext, p: EmbedParams) -> Result<Outputs, OpError> {
    if let Some(env) = &p.env {
        warn_unless_latlong_size(ctx, EmbedParams::env, env.width, env.height);
    }
    let view = &*p.view;
    let lens = Lens::new(p.model, p.fov, view.width, view.height).map_err(OpError::Invalid)?;
    let rotation = Rotation::from_yaw_pitch_roll(p.yaw, p.pitch, p.roll);
    let env = match &p.env {
        Some(env) if env.channels != view.channels => {
            return Err(OpError::Invalid(format!(
                "view has {} channels ({}) but env has {} ({}): they must match",
                view.channels,
                view.names.join(", "),
                env.channels,
                env.names.join(", ")
            )))
        }
        Some(env) => env.arc(),
        None => {
            let (w, h) = blank_size(p.width, p.height);
            let (w, h) = (w as usize, h as usize);
            std::sync::Arc::new(Image::with_names(w, h, view.names.clone(), vec![0.0; w * h * view.channels]))
        }
    };
    let (image, mask) = embed(&env, view, &lens, rotation);
    Ok(Outputs::new().port(IMAGE, image).port(MASK, mask))
}
