//! `PerPixelSphere(env, cdf, size: 256, albedo, view, strategy: Environment, spp: 16, seed: 1)`:
//! the diffuse sphere rendered as a path tracer renders direct lighting, every pixel with its
//! own `spp` independent samples (`maths::per_pixel`):
//! `Lo = (albedo / pi) (1/spp) sum_j L(w_j) max(n.w_j, 0) / pdf(w_j)`.
//!
//! - `Environment`: texel centres from `cdf` (expectation: exactly `ReferenceSphere`);
//! - `Cosine`: cosine-weighted hemisphere (Malley's method); `Uniform`: uniform sphere;
//! - `Mis`: one environment and one cosine sample per count, balance heuristic (Veach 1997).
//!
//! `Cosine`, `Uniform` and `Mis` look up the texel containing each direction, so their
//! expectation is the integral over exact texel areas, which differs from `ReferenceSphere` by
//! the midpoint rule only (O(1/H^2)). Same `size`, `albedo` and `view` fields and defaults as
//! `RelightSphere`. The image is a pure function of `seed` (per-pixel SplitMix64 streams),
//! whatever `--jobs`.

use super::{ALBEDO_FIELD, SIZE_FIELD, VIEW_FIELD};
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;
use crate::maths::per_pixel::{relight_per_pixel, PerPixelStrategy};
use crate::maths::relight::SphereView;

pub static SPEC: OpSpec = OpSpec {
    name: "PerPixelSphere",
    category: "shading",
    version: 1,
    doc: "Relight a diffuse sphere with independent samples per pixel (Environment, Cosine, Uniform or MIS)",
    fields: &[
        FieldSpec::input("env", &[ValueType::Image], "the lat-long environment (linear RGB)"),
        FieldSpec::input("cdf", &[ValueType::Distribution], "the environment's distribution (BuildCdf), same size as env"),
        SIZE_FIELD,
        ALBEDO_FIELD,
        VIEW_FIELD,
        FieldSpec {
            name: "strategy",
            kind: FieldKind::Choice(PerPixelStrategy::NAMES),
            default: Default::Choice("Environment"),
            doc: "Environment (cdf texels), Cosine (cosine hemisphere), Uniform (sphere), Mis (balance heuristic of the first two)",
        },
        FieldSpec { name: "spp", kind: FieldKind::Int { min: 1, max: 1 << 20 }, default: Default::Int(16), doc: "samples per pixel (Mis: pairs)" },
        FieldSpec {
            name: "seed",
            kind: FieldKind::Int { min: 0, max: i64::MAX },
            default: Default::Int(1),
            doc: "random seed: the same seed gives the same image, whatever --jobs",
        },
    ],
    output: OutputType::Fixed(ValueType::Image),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let env = ctx.image("env");
    let dist = ctx.distribution("cdf");
    if (dist.width, dist.height) != (env.width, env.height) {
        return Err(OpError::Invalid(format!(
            "the distribution is over a {}x{} map but env is {}x{}: build it from this env",
            dist.width, dist.height, env.width, env.height
        )));
    }
    let strategy = PerPixelStrategy::from_name(ctx.params.text("strategy")).expect("validated choice");
    let size = ctx.params.usize("size");
    let albedo = ctx.params.vec3("albedo");
    let [vt, vp] = ctx.params.vec2("view");
    let spp = ctx.params.usize("spp");
    let seed = ctx.params.int("seed") as u64;
    let view = SphereView::new(size, latlong::direction_deg(vt, vp));
    Ok(Value::image(relight_per_pixel(env, dist, &view, albedo, strategy, spp, seed)))
}
