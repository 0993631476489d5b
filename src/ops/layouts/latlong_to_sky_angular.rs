//! `LatLongToSkyAngular(env, size: 512)`: the upper hemisphere of a lat-long map as a disc seen
//! from below looking up (`geometry::azimuthal::DiscMap::SKY_ANGULAR`): the zenith (+Y) at the
//! centre, the horizon on the rim, the radius proportional to the zenith angle
//! (`r = theta / (pi / 2)`), +X on the right and -Z at the bottom (+Z at the top), as skylibs'
//! `skyangular`.
//!
//! Each `size x size` pixel whose centre is in the disc is the solid-angle mean of the map over
//! its footprint (`maths::resample::disc_image::latlong_to_disc`, leaves weighted by
//! `dOmega/dA = (pi / 2) sin(pi r / 2) / r`); outside the disc 0. `SkyAngularToLatLong` is the
//! inverse on the upper hemisphere.

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
    pub struct LatLongToSkyAngularParams {
        /// the lat-long map (any channels); its lower hemisphere is not used
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
        /// output width and height
        #[range(1, 1 << 14)]
        pub size: usize = 512,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LatLongToSkyAngular",
        3,
        "The upper hemisphere as a disc seen from below (zenith at the centre, -Z at the bottom, r = theta / 90 deg)",
        eval,
    )
    .output_like("image", |p| p.env, "the size x size sky-angular disc")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: LatLongToSkyAngularParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    Ok(Value::new(latlong_to_disc(&p.env, &DiscMap::SKY_ANGULAR, p.size)))
}
