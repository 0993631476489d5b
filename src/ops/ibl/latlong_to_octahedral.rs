//! `LatLongToOctahedral(image, size)`: a lat-long map as a size x size equal-area octahedral map,
//! pbrt-v4's layout for `ImageInfiniteLight` (what `imgtool makeequiarea` makes): pixel (x, y) is
//! centred on `EqualAreaSquareToSphere((x + 0.5) / size, (y + 0.5) / size)` in pbrt's frame,
//! which is hdrflow's `(Z, -X, Y)` (`geometry::octahedral`). Every pixel subtends 4 pi / size^2.
//! Each pixel is the solid-angle-weighted average of the lat-long map over its footprint
//! (`maths::resample::layouts`): energy-preserving, 1e-3 relative on the built-in sky (tests).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::resample::layouts::{to_octahedral, LatLongSource};
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct LatLongToOctahedralParams {
        /// the lat-long map (RGB; one channel is read as grey)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// width and height in pixels
        #[range(1, 16384)]
        pub size: usize,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LatLongToOctahedral",
        1,
        "Lat-long map to pbrt-v4's equal-area octahedral map (Clarberg; pbrt axes = hdrflow (Z, -X, Y))",
        eval,
    )
    .output("image", IMAGE_T, "the size x size octahedral RGB map")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: LatLongToOctahedralParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.image);
    let img = &*p.image;
    crate::ops::latlong_input::check_finite(img)?;
    Ok(Value::new(to_octahedral(&LatLongSource::new(img), p.size)))
}
