//! `FuseExposures(brackets)`: Mertens' exposure fusion (2007), the LDR picture photographers
//! preview: each frame's pixels weighted by contrast, saturation and well-exposedness and
//! blended through Laplacian pyramids, as OpenCV's `MergeMertens` with its default exponents
//! (`maths::capture::fusion`). Output `image`: display-referred RGB in [0, 1] (not radiance:
//! no response and no exposure time enters; save it as an 8-bit PNG with exposure 0 and no
//! transfer curve, or view it as is).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::capture::fusion::fuse;
use crate::values::brackets::Brackets;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct FuseExposuresParams {
        /// the bracketed frames (at least 2)
        #[input(&[BRACKETS_T])]
        pub brackets: Input<Brackets>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("FuseExposures", 1, "Mertens exposure fusion of bracketed frames: a display-referred [0, 1] picture", eval)
        .output("image", IMAGE_T, "the fused picture, display-referred RGB in [0, 1]")
        .into()
}

fn eval(_: &mut OpContext, p: FuseExposuresParams) -> Result<Value, OpError> {
    let b: &Brackets = &p.brackets;
    super::require_frames(b, 2)?;
    Ok(Value::new(Image::from_vec(b.width, b.height, 3, fuse(b))))
}
