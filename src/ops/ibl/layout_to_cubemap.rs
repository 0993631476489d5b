//! `LayoutToCubemap(image, layout)`: the cube map held by one image of a layout (see
//! `CubemapToLayout` and `geometry::cube_layout`), e.g. a cross loaded with `LoadHdr`.
//!
//! The image must be exactly whole faces of the layout's grid: 4:3 for `HorizontalCross` and
//! `Dice`, 3:4 for `VerticalCross` and `SkylibsCube`, 6:1 for `Horizon` and `Strip`. When its
//! size is known before running (a file header, a size parameter) anything else is a pipeline
//! error at the `image` field; otherwise the same message is the node's error when it runs. RGB is the first
//! three channels, a one-channel image is grey, alpha is ignored; cells without a face are not
//! read. Non-finite texels in a face are an error naming the face and texel.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::cube_layout::CubeLayout;
use crate::values::ty::*;
use crate::values::{Cubemap, Image};

crate::params! {
    pub struct LayoutToCubemapParams {
        /// the layout image (RGB first; one channel is read as grey)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// where each face sits and how it is turned (docs/src/guides/toolkit/cube_layouts.md)
        pub layout: CubeLayout,
    }
}

pub fn spec() -> OpSpec {
    Op::new("LayoutToCubemap", 1, "One image of a cross, dice, horizon or strip layout to a cube map", eval)
        .output("cubemap", CUBEMAP_T, "the cube map")
        .size(|_, p| {
            let s = face_size(&p)?.ok()?;
            Some((6 * s as u64, s as u64))
        })
        .check(check)
        .persist(Persist::IfSmall)
        .into()
}

/// The face size, when the image's size is known before running.
fn face_size(p: &LayoutToCubemapParams<Check>) -> Option<Result<usize, String>> {
    let (w, h) = p.image.size?;
    Some(p.layout.face_size(usize::try_from(w).ok()?, usize::try_from(h).ok()?))
}

fn check(_: &CheckContext, p: LayoutToCubemapParams<Check>) -> Result<(), CheckProblem> {
    match face_size(&p) {
        Some(Err(e)) => Err(CheckProblem::at(LayoutToCubemapParams::image, e)),
        _ => Ok(()),
    }
}

fn eval(_: &mut OpContext, p: LayoutToCubemapParams) -> Result<Value, OpError> {
    let cube = Cubemap::from_layout(&p.image, p.layout).map_err(OpError::Invalid)?;
    super::check_cube_finite(&cube)?;
    Ok(Value::new(cube))
}
