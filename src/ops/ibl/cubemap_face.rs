//! `CubemapFace(cubemap, face)`: one face of a cube map as an S x S RGB image, to `Save` as a
//! face file (`PosX` ... `NegZ`, cmft's posx ... negz), exactly as stored: texel (x, y) of face
//! F looks along `geometry::cubemap`'s table (the OpenGL / KTX faces; image right and down in
//! world axes: +X -Z, -Y; -X +Z, -Y; +Y +X, +Z; -Y +X, -Z; +Z +X, -Y; -Z -X, -Y).
//! `FacesToCubemap` of the six is the cube map again, bit for bit (tests).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::cube_layout::CubeFace;
use crate::values::ty::*;
use crate::values::Cubemap;

crate::params! {
    pub struct CubemapFaceParams {
        /// the cube map
        #[input(&[CUBEMAP_T])]
        pub cubemap: Input<Cubemap>,
        /// PosX, NegX, PosY, NegY, PosZ or NegZ
        pub face: CubeFace,
    }
}

pub fn spec() -> OpSpec {
    Op::new("CubemapFace", 1, "One face of a cube map as an image, as stored (OpenGL / KTX axes)", eval)
        .output("image", IMAGE_T, "the face (RGB, S x S)")
        .size(|_, p| p.cubemap.size.map(|(_, s)| (s, s)))
        .persist(Persist::IfSmall)
        .into()
}

fn eval(_: &mut OpContext, p: CubemapFaceParams) -> Result<Value, OpError> {
    Ok(Value::new(p.cubemap.face_image(p.face.index())))
}
