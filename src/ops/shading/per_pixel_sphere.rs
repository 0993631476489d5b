//! `PerPixelSphere(env, cdf, size: 256, albedo, view, strategy: Environment, sequence: Random, heuristic: Balance, warp: Inversion, spp: 16, seed: 1)`:
//! the diffuse sphere rendered as a path tracer renders direct lighting, every pixel with its
//! own `spp` independent samples (`maths::render::per_pixel`):
//! `Lo = (albedo / pi) (1/spp) sum_j L(w_j) max(n.w_j, 0) / pdf(w_j)`.
//!
//! - `Environment`: texel centres from `cdf` (expectation: exactly `ReferenceSphere`);
//! - `Cosine`: cosine-weighted hemisphere (Malley's method); `Uniform`: uniform sphere;
//! - `Mis`: one environment and one cosine sample per count, balance heuristic (Veach 1997), or
//!   the power heuristic with `heuristic: Power` (as Mitsuba's `direct` integrator).
//!
//! `sequence: Sobol` draws each pixel's uniforms from Owen-scrambled Sobol points instead of
//! independent random numbers (as Mitsuba's `ldsampler`): same expectation, lower error.
//! `warp: Hierarchical` draws the environment's texels by descending a mip-map of their
//! probabilities (as Mitsuba's envmap) instead of inverting CDFs: the same probabilities, so
//! the same result distribution with `Random`, but with `Sobol` the points stay spread over the
//! map's area (lower error on detailed maps such as Grace; slower per sample).
//!
//! `Cosine`, `Uniform` and `Mis` look up the texel containing each direction, so their
//! expectation is the integral over exact texel areas, which differs from `ReferenceSphere` by
//! the midpoint rule only (O(1/H^2)). Same `size`, `albedo` and `view` fields and defaults as
//! `RelightSphere`. The image is a pure function of `seed` (per-pixel SplitMix64 streams),
//! whatever `--jobs`.

use super::sphere_view;
use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::render::glossy::Heuristic;
use crate::maths::render::per_pixel::{
    relight_per_pixel_with, PerPixelOptions, PerPixelSequence, PerPixelStrategy, PerPixelWarp,
};
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Distribution2D;
use crate::values::Image;

super::sphere_params! {
    PerPixelParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// the environment's distribution (BuildCdf), same size as env
        #[input(&[DISTRIBUTION_T])]
        pub cdf: Input<Distribution2D>,
    } {
        /// Environment (cdf texels), Cosine (cosine hemisphere), Uniform (sphere), Mis (balance heuristic of the first two)
        pub strategy: PerPixelStrategy = PerPixelStrategy::Environment,
        /// Random (independent uniforms) or Sobol (per-pixel Owen-scrambled Sobol, as Mitsuba's ldsampler)
        pub sequence: PerPixelSequence = PerPixelSequence::Random,
        /// Mis only: Balance or Power heuristic (Mitsuba's direct integrator uses Power)
        pub heuristic: Heuristic = Heuristic::Balance,
        /// Environment and Mis: Inversion (CDF inversion through guide tables, fastest) or Hierarchical (mip-map descent as Mitsuba's envmap, better with Sobol)
        pub warp: PerPixelWarp = PerPixelWarp::Inversion,
        /// samples per pixel (Mis: pairs)
        #[range(1, 1 << 20)]
        pub spp: usize = 16,
        /// random seed: the same seed gives the same image, whatever --jobs
        pub seed: u64 = 1,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "PerPixelSphere",
        1,
        "Relight a diffuse sphere with independent samples per pixel (Environment, Cosine, Uniform or MIS)",
        eval,
    )
    .output("image", IMAGE_T, "the relit sphere")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .check(|_, p| super::check_env_cdf_sizes(p.env, p.cdf))
    .persist(Persist::Always)
    .into()
}

fn eval(ctx: &mut OpContext, p: PerPixelParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let (env, dist) = (&*p.env, &*p.cdf);
    if (dist.width(), dist.height()) != (env.width, env.height) {
        return Err(OpError::Invalid(format!(
            "the distribution is over a {}x{} map but env is {}x{}: build it from this env",
            dist.width(),
            dist.height(),
            env.width,
            env.height
        )));
    }
    let view = sphere_view(p.size, p.view);
    let options = PerPixelOptions {
        strategy: p.strategy,
        sequence: p.sequence,
        heuristic: p.heuristic,
        warp: p.warp,
        spp: p.spp,
        seed: p.seed,
    };
    Ok(Value::new(relight_per_pixel_with(env, dist, &view, p.albedo.0, &options)))
}
