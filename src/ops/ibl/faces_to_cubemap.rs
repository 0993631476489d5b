//! `FacesToCubemap(px, nx, py, ny, pz, nz)`: a cube map from six face images (typically six
//! `LoadHdr`), each as `CubemapFace` writes it: the OpenGL / KTX faces of `geometry::cubemap`,
//! which are also cmft's `--inputFacePosX` ... `--inputFaceNegZ`. (py360convert's face lists,
//! F R B L U D, are turned differently: its F, R, B, L are -Z, +X, +Z, -X mirrored left-right,
//! its U, D are +Y, -Y mirrored top-bottom; its `horizon` image of them reads with
//! `LayoutToCubemap(layout: Horizon)`.)
//!
//! The faces must be square and of one size: a pipeline error at the offending field when the
//! sizes are known before running, the node's error when it runs otherwise. RGB is the first
//! three channels, one channel is grey, alpha is ignored; non-finite texels are an error.

use crate::engine::fields::{Check, Input, Shape};
use crate::engine::op::{check_same_size, CheckContext, CheckProblem, OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::{Cubemap, Image};

crate::params! {
    pub struct FacesToCubemapParams {
        /// the +X face (image right -Z, down -Y)
        #[input(ANY_IMAGE)]
        pub px: Input<Image>,
        /// the -X face (right +Z, down -Y)
        #[input(ANY_IMAGE)]
        pub nx: Input<Image>,
        /// the +Y face, up (right +X, down +Z)
        #[input(ANY_IMAGE)]
        pub py: Input<Image>,
        /// the -Y face, down (right +X, down -Z)
        #[input(ANY_IMAGE)]
        pub ny: Input<Image>,
        /// the +Z face, back (right +X, down -Y)
        #[input(ANY_IMAGE)]
        pub pz: Input<Image>,
        /// the -Z face, forward (right -X, down -Y)
        #[input(ANY_IMAGE)]
        pub nz: Input<Image>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("FacesToCubemap", 1, "Six face images (+X -X +Y -Y +Z -Z, OpenGL / KTX axes) to a cube map", eval)
        .output("cubemap", CUBEMAP_T, "the cube map")
        .size(|_, p| p.px.size.map(|(s, _)| (6 * s, s)))
        .check(check)
        .persist(Persist::IfSmall)
        .into()
}

fn check(_: &CheckContext, p: FacesToCubemapParams<Check>) -> Result<(), CheckProblem> {
    let shapes: [Shape; 6] = [p.px, p.nx, p.py, p.ny, p.pz, p.nz];
    for shape in shapes {
        if let Some((w, h)) = shape.size.filter(|(w, h)| w != h) {
            return Err(CheckProblem::at(
                shape.field,
                format!("{:?} is {w}x{h}: a cube face must be square", shape.field),
            ));
        }
        check_same_size(shapes[0], shape)?;
    }
    Ok(())
}

fn eval(_: &mut OpContext, p: FacesToCubemapParams) -> Result<Value, OpError> {
    let cube = Cubemap::from_faces([&p.px, &p.nx, &p.py, &p.ny, &p.pz, &p.nz]).map_err(OpError::Invalid)?;
    super::check_cube_finite(&cube)?;
    Ok(Value::new(cube))
}
