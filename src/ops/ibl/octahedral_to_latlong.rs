//! `OctahedralToLatLong(image, width, height)`: a square equal-area octahedral map (pbrt-v4's
//! layout, `geometry::octahedral`) as a W x H lat-long RGB map, each texel the solid-angle-weighted
//! average of the octahedral map over its footprint (`maths::resample::layouts`).

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::resample::layouts::{to_latlong, OctahedralSource};
use crate::values::ty::*;
use crate::values::Image;

super::latlong_size_params!(OctahedralToLatLongParams {
    /// the square octahedral map (RGB; one channel is read as grey)
    #[input(ANY_IMAGE)]
    pub image: Input<Image>,
});

pub fn spec() -> OpSpec {
    Op::new("OctahedralToLatLong", 1, "pbrt-v4 equal-area octahedral map to lat-long map (energy-preserving)", eval)
        .output("image", IMAGE_T, "the lat-long RGB map")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .check(check)
        .into()
}

fn check(_: &CheckContext, p: OctahedralToLatLongParams<Check>) -> Result<(), CheckProblem> {
    match p.image.size {
        Some((w, h)) if w != h => {
            Err(CheckProblem::at(p.image.field, format!("an octahedral map is square, not {w}x{h}")))
        }
        _ => Ok(()),
    }
}

fn eval(_: &mut OpContext, p: OctahedralToLatLongParams) -> Result<Value, OpError> {
    let img = &*p.image;
    if img.width != img.height || img.width == 0 {
        return Err(OpError::Invalid(format!("an octahedral map is square, not {}x{}", img.width, img.height)));
    }
    crate::ops::latlong_input::check_finite(img)?;
    Ok(Value::new(to_latlong(&OctahedralSource::new(img), p.width, p.height)))
}
