//! `CubemapToLayout(cubemap, layout)`: a cube map as one image: `HorizontalCross` (4:3) and
//! `VerticalCross` (3:4) as cmft lays them out, py360convert's `Dice` (4:3) and `Horizon` (6:1),
//! skylibs' `SkylibsCube` (3:4), or hdrflow's `Strip` (6:1, what `Save` writes). Cells, turns
//! and each face's orientation in world axes: `geometry::cube_layout`.
//!
//! A copy: every texel lands unchanged in its cell, cells without a face are 0, so
//! `LayoutToCubemap` of the result gives the cube map back bit for bit (tests, every layout).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::cube_layout::CubeLayout;
use crate::values::ty::*;
use crate::values::Cubemap;

crate::params! {
    pub struct CubemapToLayoutParams {
        /// the cube map
        #[input(&[CUBEMAP_T])]
        pub cubemap: Input<Cubemap>,
        /// where each face sits and how it is turned (docs/src/guides/toolkit/cube_layouts.md)
        pub layout: CubeLayout,
    }
}

pub fn spec() -> OpSpec {
    Op::new("CubemapToLayout", 1, "Cube map to one image: a cross, dice, horizon or strip of its six faces", eval)
        .output("image", IMAGE_T, "the layout (RGB; cells without a face are 0)")
        .size(|_, p| {
            let (_, s) = p.cubemap.size?;
            let (w, h) = p.layout.image_size(usize::try_from(s).ok()?);
            Some((w as u64, h as u64))
        })
        .persist(Persist::IfSmall)
        .into()
}

fn eval(_: &mut OpContext, p: CubemapToLayoutParams) -> Result<Value, OpError> {
    Ok(Value::new(p.cubemap.to_layout(p.layout)))
}
