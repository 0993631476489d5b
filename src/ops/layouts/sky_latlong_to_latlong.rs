//! `SkyLatLongToLatLong(image, fill: [])`: a W x h sky lat-long map (the upper hemisphere, as
//! `LatLongToSkyLatLong` makes it) back to a W x 2h lat-long map: the upper h rows are the
//! input, bit for bit; the lower hemisphere is the constant `fill` per channel (none given: 0;
//! one number: every channel; else one per channel). Port `mask`: 1 on the sky rows, 0 below.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::values::ty::*;
use crate::values::Image;

use super::fill_values;

crate::params! {
    pub struct SkyLatLongToLatLongParams {
        /// the sky lat-long map (the upper hemisphere, zenith in row 0)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// the lower hemisphere's value: [] is 0, [v] every channel, or one per channel
        pub fill: Vec<f64> = Vec::new(),
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const IMAGE: Port<Image> = Port::new("image");
const MASK: Port<Image> = Port::new("mask");

pub fn spec() -> OpSpec {
    Op::new(
        "SkyLatLongToLatLong",
        1,
        "A sky lat-long map (upper hemisphere) to a full lat-long map, the lower hemisphere a constant fill",
        eval,
    )
    .output_like(IMAGE, |p| p.image, "the W x 2h lat-long map")
    .port(MASK, SCALAR_T, "1 on the sky (upper) rows, 0 on the filled ones")
    .size(|_, p| p.image.size.map(|(w, h)| (w, 2 * h)))
    .into()
}

fn eval(_: &mut OpContext, p: SkyLatLongToLatLongParams) -> Result<Outputs, OpError> {
    let sky = &*p.image;
    let (w, h, c) = (sky.width, sky.height, sky.channels);
    let fill = fill_values(&p.fill, c)?;
    let mut data = Vec::with_capacity(w * 2 * h * c);
    data.extend_from_slice(&sky.data);
    for _ in 0..w * h {
        data.extend_from_slice(&fill);
    }
    let mut mask = vec![1.0f32; w * h];
    mask.resize(w * 2 * h, 0.0);
    let image = Image::with_names(w, 2 * h, sky.names.clone(), data);
    Ok(Outputs::new().port(IMAGE, image).port(MASK, Image::from_vec(w, 2 * h, 1, mask)))
}
