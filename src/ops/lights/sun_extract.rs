//! `SunExtract(env, threshold_stops: 8)`: the sun of an environment map as a `light`, and the
//! map without it, conserving the map's integral exactly (`maths::fit::sun`).
//!
//! - The sun region is the connected set of texels (8-connected, wrapping in longitude and
//!   across the poles) around the brightest texel whose Rec. 709 luminance exceeds
//!   `m 2^threshold_stops`, where `m` is the **median** texel luminance (the solid-angle-weighted
//!   mean when the median is 0, i.e. a map more than half black).
//! - Port `residual`: the map with the region's colour set to the fill colour, the
//!   solid-angle-weighted mean of the ring of texels around the region (clamped per channel to
//!   the region's minimum, so the sun is never negative); alpha and other channels kept.
//! - Port `sun`: direction = the normalised centroid of the region's texel directions weighted by
//!   the luminance removed; solid_angle = the sum of the region's texel solid angles;
//!   radiance = (integral over the region - fill integral over the region) / solid_angle, per
//!   channel.
//!
//! So, per channel, `integral(residual) + radiance * solid_angle = integral(env)` by
//! construction (f64 sums; the tests check 1e-4 relative on every shared real map and on
//! synthetic ones; it holds to ~1e-12). No texel above the threshold (a uniform or black map):
//! zero radiance and solid angle, `residual = env`. NaN or infinite texels are an error.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::fit::sun::extract_sun_in_place;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;
use crate::values::Light;

crate::params! {
    pub struct SunExtractParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// the sun is what exceeds the median luminance by this many stops (x 2^threshold_stops)
        #[range(0.0, 64.0)]
        pub threshold_stops: f64 = 8.0,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const SUN: Port<Light> = Port::new("sun");
const RESIDUAL: Port<Image> = Port::new("residual");

pub fn spec() -> OpSpec {
    Op::new(
        "SunExtract",
        1,
        "Split an environment into a sun (light) and the map without it, conserving the integral per channel",
        eval,
    )
    .port(SUN, LIGHT_T, "the sun: direction, solid angle, RGB radiance (zero if none)")
    .output_like(RESIDUAL, |p| p.env, "env with the sun's texels filled from around them")
    .into()
}

fn eval(ctx: &mut OpContext, p: SunExtractParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    check_finite(&p.env)?;
    // The residual is the map itself with the sun filled: no second copy when no other node
    // reads the map (else `take` copies it).
    let s = extract_sun_in_place(p.env.take(), p.threshold_stops);
    Ok(Outputs::new().port(SUN, s.light).port(RESIDUAL, s.residual))
}
