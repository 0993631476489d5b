//! `RelightSphere(env, samples, size, albedo, view, estimator: Unbiased)`: a diffuse sphere seen
//! orthographically from `view` = (theta, phi) in degrees, its silhouette inscribed in the
//! `size` x `size` image, black background, lit by the environment through the given samples,
//! shared by every pixel as in the seed.
//!
//! - `Unbiased`: Lo(n) = (albedo/pi) * (1/N) * sum_j L(w_j) max(n.w_j, 0) / pdf(w_j), the Monte
//!   Carlo estimate of (albedo/pi) * integral of L(w) max(n.w, 0) dw. Its expectation is the
//!   exact sum over texels that `ReferenceSphere` computes.
//! - `Seed`: the seed's formula exactly, L = (integral of L dw / N) * sum_j (1/pi) max(cos, 0) V_j
//!   with V_j = rgb_j / |rgb_j| (times albedo). The integral is that of the map's Rec. 709
//!   luminance over the sphere. Against `Unbiased` with a luminance-proportional pdf (where
//!   L/pdf = rgb/Y * integral), it replaces rgb/Y by rgb/|rgb|: for grey light |rgb| = sqrt(3) Y,
//!   so the seed is sqrt(3) = 1.73x too dark, and its hue shifts towards the dominant channel.
//!
//! Samples that land on one texel are merged into one light of summed weight (exact: every
//! pixel sees the same direction), pixels off the disc cost nothing, and samples behind a
//! pixel's surface add nothing (max(cos, 0)).

use super::{ALBEDO_FIELD, SIZE_FIELD, VIEW_FIELD};
use crate::data::{Image, SampleSet};
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;
use crate::maths::relight::{merge_duplicates, relight, Estimator, LightSample, SphereView};

pub static SPEC: OpSpec = OpSpec {
    name: "RelightSphere",
    category: "shading",
    version: 1,
    doc: "Relight a diffuse sphere with an environment through shared light samples",
    fields: &[
        FieldSpec::input("env", &[ValueType::Image], "the lat-long environment (linear RGB)"),
        FieldSpec::input("samples", &[ValueType::Samples], "light samples (Sample), shared by every pixel"),
        SIZE_FIELD,
        ALBEDO_FIELD,
        VIEW_FIELD,
        FieldSpec {
            name: "estimator",
            kind: FieldKind::Choice(&["Unbiased", "Seed"]),
            default: Default::Choice("Unbiased"),
            doc: "Unbiased: (albedo/pi) mean(L cos / pdf); Seed: the seed's formula exactly",
        },
    ],
    output: OutputType::Fixed(ValueType::Image),
    eval,
    content_key: None,
    check: None,
};

/// The integral of the map's Rec. 709 luminance over the sphere: sum of Y * texel solid angle.
pub fn luminance_integral(env: &Image) -> f64 {
    (0..env.height)
        .map(|y| {
            let d_omega = latlong::texel_solid_angle(y, env.width, env.height);
            let row: f64 = (0..env.width)
                .map(|x| {
                    let [r, g, b] = env.rgb(x, y);
                    0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64
                })
                .filter(|v| v.is_finite())
                .sum();
            row * d_omega
        })
        .sum()
}

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let [vt, vp] = ctx.params.vec2("view");
    let estimator = if ctx.params.text("estimator") == "Seed" { Estimator::Seed } else { Estimator::Unbiased };
    let image = relight_shared(
        ctx.image("env"),
        ctx.samples("samples"),
        ctx.params.usize("size"),
        ctx.params.vec3("albedo"),
        latlong::direction_deg(vt, vp),
        estimator,
    )?;
    Ok(Value::image(image))
}

/// The operator's work, callable from code (the benchmark uses it): relight a `size` x `size`
/// sphere seen from `view_dir` with `set`'s samples of `env`.
pub fn relight_shared(
    env: &Image,
    set: &SampleSet,
    size: usize,
    albedo: [f64; 3],
    view_dir: [f64; 3],
    estimator: Estimator,
) -> Result<Image, OpError> {
    let same_grid = set.width as usize == env.width && set.height as usize == env.height;
    let mut lights: Vec<(u32, LightSample)> = Vec::with_capacity(set.samples.len());
    for s in &set.samples {
        let (x, y) = if same_grid {
            (s.x as usize, s.y as usize)
        } else {
            latlong::texel_of_direction([s.dir[0] as f64, s.dir[1] as f64, s.dir[2] as f64], env.width, env.height)
        };
        let rgb = env.rgb(x, y);
        let light = match estimator {
            Estimator::Seed => LightSample::seed(s.dir, rgb),
            Estimator::Unbiased => LightSample::unbiased(s.dir, rgb, s.pdf),
        };
        if light.weight.iter().any(|w| !w.is_finite()) {
            return Err(OpError::Invalid(format!(
                "texel ({x}, {y}) gives a non-finite light weight {:?} (radiance {rgb:?}, pdf {})",
                light.weight, s.pdf
            )));
        }
        lights.push(((y * env.width + x) as u32, light));
    }
    let merged = merge_duplicates(&lights);
    if let Some(l) = merged.iter().find(|l| l.weight.iter().any(|w| !w.is_finite())) {
        return Err(OpError::Invalid(format!(
            "samples merged on one texel (direction {:?}) sum to a weight beyond f32 range: the map's radiance over pdf overflows",
            l.dir
        )));
    }
    // The luminance integral is a full pass over the map: only the seed's formula needs it.
    let integral = if estimator == Estimator::Seed { luminance_integral(env) } else { 0.0 };
    let scale = estimator.scale(albedo, set.samples.len(), integral);
    if scale.iter().any(|s| !s.is_finite()) {
        return Err(OpError::Invalid(format!("the estimator's scale {scale:?} is beyond f32 range")));
    }
    let image = relight(&SphereView::new(size, view_dir), &merged, scale);
    if let Some(i) = image.data.iter().position(|v| !v.is_finite()) {
        let px = i / 3;
        return Err(OpError::Invalid(format!(
            "relit radiance at pixel ({}, {}) overflows f32 (largest 3.4e38): scale the map down with Exposure",
            px % size,
            px / size
        )));
    }
    Ok(image)
}
