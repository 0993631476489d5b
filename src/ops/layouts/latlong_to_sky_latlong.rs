//! `LatLongToSkyLatLong(env)`: the upper hemisphere of a W x H lat-long map, as outdoor sky
//! datasets store it (skylibs' `skylatlong`): its first H/2 rows, copied bit for bit, a W x H/2
//! image whose row y is centred on the zenith angle `theta = pi (y + 0.5) / H`, from the zenith
//! (row 0) down to the horizon (the bottom edge); columns as the lat-long's (the centre column
//! faces -Z). An odd H has no row boundary at the horizon and is refused (before the run when
//! the size is known). `SkyLatLongToLatLong` is the inverse.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Image;

use super::check_even_height;

crate::params! {
    pub struct LatLongToSkyLatLongParams {
        /// the lat-long map (any channels), of even height
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("LatLongToSkyLatLong", 1, "The upper hemisphere of a lat-long map: its upper half rows, exactly", eval)
        .output_like("image", |p| p.env, "the W x H/2 sky lat-long map")
        .size(|_, p| p.env.size.map(|(w, h)| (w, h / 2)))
        .check(check)
        .into()
}

fn check(_: &CheckContext, p: LatLongToSkyLatLongParams<Check>) -> Result<(), CheckProblem> {
    check_even_height("env", p.env)
}

/// The upper half rows of `env` (an even height), names kept.
pub fn sky_half(env: &Image) -> Result<Image, OpError> {
    let (w, h, c) = (env.width, env.height, env.channels);
    if h % 2 == 1 {
        return Err(OpError::Invalid(format!("\"env\" is {w}x{h}: an odd height has no row boundary at the horizon")));
    }
    Ok(Image::with_names(w, h / 2, env.names.clone(), env.data[..w * (h / 2) * c].to_vec()))
}

fn eval(ctx: &mut OpContext, p: LatLongToSkyLatLongParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    Ok(Value::new(sky_half(&p.env)?))
}
