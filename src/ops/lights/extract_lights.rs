//! `ExtractLights(env, max_lights: 3, threshold_stops: 8)`: parametric lights (the `max_lights`
//! most energetic connected bright regions) and an ambient colour, as a `lights` value, and the
//! map with those regions filled, conserving the map's integral exactly (`maths::fit::lights`).
//!
//! - Regions: the connected sets of texels (8-connected, wrapping across the seam and the poles,
//!   as `SunExtract`) whose Rec. 709 luminance exceeds `m 2^threshold_stops`, `m` the median
//!   texel luminance (the solid-angle-weighted mean when the median is 0); the `max_lights` of
//!   largest luminance integral are the lights, most energetic first.
//! - Port `lights`: each light's `direction` (normalised luminance-weighted centroid),
//!   `solid_angle` (sum of its texels' solid angles) and `radiance = max(M - A, 0)` per channel
//!   (`M` its region's mean radiance); `ambient` `A` solves, per channel,
//!   `sum_i radiance_i solid_angle_i + A 4 pi = integral(env)` (exact in f64): it is the mean
//!   radiance of everything but the lights, over the rest of the sphere.
//! - Port `residual`: the map with each light's texels set to `M - radiance` (the ambient, or
//!   the region's own mean in a clamped channel), so `integral(residual) + sum_i radiance_i
//!   solid_angle_i = integral(env)` too, up to f32 rounding (tests: 1e-6); alpha kept.
//!
//! Directions use hdrflow's lat-long convention (+Y up, the centre column faces -Z). The tests
//! check both identities to 1e-12 / 1e-6 relative on `builtin:sky`, `builtin:studio` and
//! synthetic maps with 0, 1, 3 and 5 blobs (one across the seam, one around the north pole).
//! NaN or infinite texels are an error.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::fit::lights::extract_lights;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;
use crate::values::Lights;

crate::params! {
    pub struct ExtractLightsParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// how many lights at most (the most energetic regions)
        #[range(1, 64)]
        pub max_lights: usize = 3,
        /// a light is a region above the median luminance by this many stops (x 2^threshold_stops)
        #[range(0.0, 64.0)]
        pub threshold_stops: f64 = 8.0,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const LIGHTS: Port<Lights> = Port::new("lights");
const RESIDUAL: Port<Image> = Port::new("residual");

pub fn spec() -> OpSpec {
    Op::new(
        "ExtractLights",
        1,
        "Parametric lights (the brightest connected regions) plus an ambient colour, conserving the integral per channel",
        eval,
    )
    .port(LIGHTS, LIGHTS_T, "the lights (direction, solid angle, RGB radiance) and the ambient")
    .output_computed(
        RESIDUAL,
        "the input's type",
        |_, p| Ok(p.env.ty),
        "env with the lights' regions filled with the ambient",
    )
    .into()
}

fn eval(ctx: &mut OpContext, p: ExtractLightsParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let env = &*p.env;
    check_finite(env)?;
    let e = extract_lights(env, p.max_lights, p.threshold_stops);
    Ok(Outputs::new().port(LIGHTS, e.lights).port(RESIDUAL, e.residual))
}
