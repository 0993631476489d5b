//! `LatLongToAngular(env, size: 512)`: a lat-long map as a Debevec angular probe, the inverse of
//! `AngularToLatLong` (same convention: forward -Z at the centre, +X right, +Y up, the angle from
//! forward pi r, the back direction +Z on the rim; `geometry::azimuthal::DiscMap::ANGULAR`).
//!
//! Each `size x size` pixel whose centre is in the disc is the solid-angle mean of the map over
//! its footprint (`maths::resample::disc_image::latlong_to_disc`, leaves weighted by
//! `dOmega/dA = pi sin(pi r) / r`); outside the disc 0. The tests check the round trip
//! lat-long -> angular -> lat-long and that the integral is kept (1e-3 on the sky).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::azimuthal::DiscMap;
use crate::maths::resample::disc_image::latlong_to_disc;
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct LatLongToAngularParams {
        /// the lat-long map (any channels)
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
        /// output width and height
        #[range(1, 1 << 14)]
        pub size: usize = 512,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LatLongToAngular",
        3,
        "A lat-long map as a Debevec angular probe (footprint-averaged; outside the disc 0)",
        eval,
    )
    .output_like("image", |p| p.env, "the size x size angular probe")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: LatLongToAngularParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    Ok(Value::new(latlong_to_disc(&p.env, &DiscMap::ANGULAR, p.size)))
}
