//! `SunExtract(env, threshold_stops: 8, max_radius_deg: 3, min_share: 0.1)`: the sun of an
//! environment map as a `light`, and the map without it, conserving the map's integral exactly
//! (`maths::fit::sun`).
//!
//! - The sun region is the connected set of texels (8-connected, wrapping in longitude and
//!   across the poles) around the brightest texel whose Rec. 709 luminance exceeds
//!   `m 2^threshold_stops`, where `m` is the **median** texel luminance (the solid-angle-weighted
//!   mean when the median is 0, i.e. a map more than half black).
//! - It is a sun only if small and carrying much of the light (`maths::fit::sun_rule`): the cone
//!   of its solid angle at most `max_radius_deg` wide (half angle), its light at least
//!   `min_share` of the map's luminous integral. Else it stays in the map (no light, `residual =
//!   env`) and a warning gives its size and share: a studio's softbox or a lamp is not a sun.
//! - Port `metrics`: `found` (1 or 0), `share` (the light's fraction of the map's luminous
//!   integral), `radius_deg`, `texels`, and `region_share` / `region_radius_deg` of the brightest
//!   region whether or not it was taken (0 when none exceeds the threshold).
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
use crate::maths::fit::sun::extract_sun_by;
use crate::maths::fit::sun_rule::{cone_radius_deg, SunRule};
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;
use crate::values::Light;
use crate::values::Metrics;

crate::params! {
    pub struct SunExtractParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// the sun is what exceeds the median luminance by this many stops (x 2^threshold_stops)
        #[range(0.0, 64.0)]
        pub threshold_stops: f64 = 8.0,
        /// the widest region taken for a sun: the half angle (degrees) of the cone of its solid angle
        #[range(0.0, 180.0)]
        pub max_radius_deg: f64 = 3.0,
        /// the least light a sun carries, as a fraction of the map's luminous integral
        #[range(0.0, 1.0)]
        pub min_share: f64 = 0.1,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const SUN: Port<Light> = Port::new("sun");
const RESIDUAL: Port<Image> = Port::new("residual");
const METRICS: Port<Metrics> = Port::new("metrics");

pub fn spec() -> OpSpec {
    Op::new(
        "SunExtract",
        2,
        "Split an environment into a sun (light) and the map without it, conserving the integral per channel",
        eval,
    )
    .port(SUN, LIGHT_T, "the sun: direction, solid angle, RGB radiance (zero if none)")
    .output_like(RESIDUAL, |p| p.env, "env with the sun's texels filled from around them")
    .port(METRICS, METRICS_T, "found, share, radius_deg, texels; region_share, region_radius_deg")
    .into()
}

fn eval(ctx: &mut OpContext, p: SunExtractParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    check_finite(&p.env)?;
    // The residual is the map itself with the sun filled: no second copy when no other node
    // reads the map (else `take` copies it).
    let rule = SunRule { threshold_stops: p.threshold_stops, max_radius_deg: p.max_radius_deg, min_share: p.min_share };
    let s = extract_sun_by(p.env.take(), &rule);
    if let Some(r) = &s.rejected {
        ctx.warn(r.to_string());
    }
    let radius = cone_radius_deg(s.light.solid_angle);
    // The brightest region's numbers, taken or not.
    let (region_share, region_radius) = s.rejected.map_or((s.share, radius), |r| (r.share, r.radius_deg));
    let metrics = Metrics {
        fields: vec![
            ("found".into(), if s.texels > 0 { 1.0 } else { 0.0 }),
            ("share".into(), s.share),
            ("radius_deg".into(), radius),
            ("texels".into(), s.texels as f64),
            ("region_share".into(), region_share),
            ("region_radius_deg".into(), region_radius),
        ],
    };
    Ok(Outputs::new().port(SUN, s.light).port(RESIDUAL, s.residual).port(METRICS, metrics))
}
