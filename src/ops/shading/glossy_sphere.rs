//! `GlossySphere(env, cdf, exponent: 10, diffuse: 0.2, specular: 0.8, spp: 16, strategy: Mis,
//! heuristic: Power, seed: 1, size: 256, view: (90, 90))`: a sphere with the modified Phong
//! BRDF `f = diffuse / pi + specular (s + 2) / (2 pi) cos^s(alpha)` (alpha from the mirror
//! direction of the view; Lafortune and Willems 1994), rendered per pixel by Monte Carlo with
//! `spp` radiance lookups (`maths::render::glossy`):
//!
//! - `Environment`: texels from `cdf`, a point uniform in solid angle inside each;
//! - `Brdf`: the diffuse (cosine) or the Phong lobe (the seed's sampler, `PhongSample`'s),
//!   chosen in proportion to the channel means of `diffuse` and `specular`, weighted by the
//!   mixture density;
//! - `Mis`: ceil(spp/2) environment and floor(spp/2) BRDF samples, combined by the `heuristic`
//!   (`Power`, beta = 2, or `Balance`; Veach 1997, section 9.2).
//!
//! Every strategy is unbiased for the integral of the piecewise-constant map; it converges to
//! `ReferenceGlossySphere` up to that operator's midpoint rule (O(s h^2), h the texel angle).
//! Same `size` and `view` fields and defaults as the other sphere renderers. The image is a
//! pure function of `seed` (per-pixel SplitMix64 streams), whatever `--jobs`. NaN or infinite
//! texels are an error (they would make NaN pixels).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::render::glossy::{glossy_sphere, GlossyBrdf, GlossyStrategy, Heuristic};
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Distribution2D;
use crate::values::Image;

super::glossy_params! {
    GlossySphereParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// the environment's distribution (BuildCdf), same size as env
        #[input(&[DISTRIBUTION_T])]
        pub cdf: Input<Distribution2D>,
    } {
        /// samples per pixel: radiance lookups (Mis: ceil(spp/2) environment + floor(spp/2) BRDF)
        #[range(1, 1 << 20)]
        pub spp: usize = 16,
        /// Environment (cdf), Brdf (diffuse or Phong lobe), Mis (both, weighted by the heuristic)
        pub strategy: GlossyStrategy = GlossyStrategy::Mis,
        /// Mis weights: Power (beta = 2) or Balance
        pub heuristic: Heuristic = Heuristic::Power,
        /// random seed: the same seed gives the same image, whatever --jobs
        pub seed: u64 = 1,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "GlossySphere",
        1,
        "A modified-Phong sphere with per-pixel samples: Environment, Brdf or Mis (power or balance heuristic)",
        eval,
    )
    .output("image", IMAGE_T, "the glossy sphere")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .check(|_, p| super::check_env_cdf_sizes(p.env, p.cdf))
    .into()
}

fn eval(ctx: &mut OpContext, p: GlossySphereParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let (env, dist) = (&*p.env, &*p.cdf);
    // A NaN or infinite texel would make NaN pixels wherever a sample lands on it.
    crate::ops::latlong_input::check_finite(env)?;
    if (dist.width(), dist.height()) != (env.width, env.height) {
        return Err(OpError::Invalid(format!(
            "the distribution is over a {}x{} map but env is {}x{}: build it from this env",
            dist.width(),
            dist.height(),
            env.width,
            env.height
        )));
    }
    let brdf = GlossyBrdf { diffuse: p.diffuse.0, specular: p.specular.0, exponent: p.exponent };
    let view = super::sphere_view(p.size, p.view);
    Ok(Value::new(glossy_sphere(env, dist, &view, &brdf, p.strategy, p.heuristic, p.spp, p.seed)))
}
