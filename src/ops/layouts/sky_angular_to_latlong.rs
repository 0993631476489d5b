//! `SkyAngularToLatLong(image, width: 1024, height: 512, fill: [])`: a sky-angular disc (the
//! upper hemisphere seen from below, zenith at the centre, -Z at the bottom, `r = theta / (pi /
//! 2)`; see `LatLongToSkyAngular`) to a lat-long map.
//!
//! Each texel is a bilinear lookup at its centre direction's disc point, taps whose pixel centres
//! lie outside the disc weighing 0 (`maths::resample::disc_image::disc_to_latlong`). The lower hemisphere,
//! which the disc does not hold, is the constant `fill` per channel (none given: 0; one number:
//! every channel; else one per channel). Port `mask`: 1 where the disc saw the texel (the upper
//! hemisphere), 0 where it was filled. A non-square image is an error (before the run when its
//! size is known).

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::geometry::azimuthal::DiscMap;
use crate::maths::resample::disc_image::disc_to_latlong;
use crate::values::ty::*;
use crate::values::Image;

use super::{check_square, fill_unseen, fill_values, require_square};

crate::params! {
    pub struct SkyAngularToLatLongParams {
        /// the sky-angular disc (square)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// output width
        #[range(1, 1 << 28)]
        pub width: usize = 1024,
        /// output height
        #[range(1, 1 << 28)]
        pub height: usize = 512,
        /// the lower hemisphere's value: [] is 0, [v] every channel, or one per channel
        pub fill: Vec<f64> = Vec::new(),
    }
}

const WHAT: &str = "a sky-angular";

/// The output ports, declared once: the spec and `eval` name them through these.
const IMAGE: Port<Image> = Port::new("image");
const MASK: Port<Image> = Port::new("mask");

pub fn spec() -> OpSpec {
    Op::new(
        "SkyAngularToLatLong",
        1,
        "A sky-angular disc (upper hemisphere seen from below) to a lat-long map, the lower hemisphere a constant fill",
        eval,
    )
    .output_like(IMAGE, |p| p.image, "the lat-long map")
    .port(MASK, SCALAR_T, "1 where the disc saw the texel, 0 where it was filled")
    .size(|_, p| Some((p.width as u64, p.height as u64)))
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: SkyAngularToLatLongParams<Check>) -> Result<(), CheckProblem> {
    check_square("image", p.image, WHAT)
}

fn eval(_: &mut OpContext, p: SkyAngularToLatLongParams) -> Result<Outputs, OpError> {
    require_square(&p.image, "image", WHAT)?;
    let fill = fill_values(&p.fill, p.image.channels)?;
    let mut out = disc_to_latlong(&p.image, &DiscMap::SKY_ANGULAR, 1.0, p.width, p.height);
    fill_unseen(&mut out.image, &out.mask, &fill);
    Ok(Outputs::new().port(IMAGE, out.image).port(MASK, out.mask))
}
