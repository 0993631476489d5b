//! `RelightSphere(env, samples, size, albedo, view, estimator: Unbiased)`: a diffuse sphere seen
//! orthographically from `view` = (theta, phi) in degrees, its silhouette inscribed in the
//! `size` x `size` image, black background, lit by the environment through the given samples,
//! shared by every pixel as in the seed.
//!
//! - `Unbiased`: Lo(n) = (albedo/pi) * (1/N) * sum_j L(w_j) max(n.w_j, 0) / pdf(w_j), the Monte
//!   Carlo estimate of (albedo/pi) * integral of L(w) max(n.w, 0) dw. Its expectation is the
//!   exact sum over texels that `ReferenceSphere` computes.
//! - `Seed`: the seed's formula exactly, L = (integral of L dw / N) * sum_j (1/pi) max(cos, 0) V_j
//!   with V_j = rgb_j / |rgb_j| (times albedo). The integral is that of the Rec. 709 luminance
//!   of the map the samples' distribution was built from (`SampleSet::luminance_integral`), so
//!   samples drawn from a distribution over another resolution scale correctly. Against `Unbiased` with a luminance-proportional pdf (where
//!   L/pdf = rgb/Y * integral), it replaces rgb/Y by rgb/|rgb|: for grey light |rgb| = sqrt(3) Y,
//!   so the seed is sqrt(3) = 1.73x too dark, and its hue shifts towards the dominant channel.
//!
//! Samples that land on one texel are merged into one light of summed weight (exact: every
//! pixel sees the same direction), pixels off the disc cost nothing, and samples behind a
//! pixel's surface add nothing (max(cos, 0)).

use super::sphere_view;
use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem};
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::params::Rgb;
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::maths::colour::rec709_luminance as rec709;
use crate::maths::relight::{merge_duplicates, relight, Estimator, LightSample, SphereView};
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Image;
use crate::values::SampleSet;

super::sphere_params! {
    RelightParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// light samples (Sample), shared by every pixel
        #[input(&[SAMPLES_T])]
        pub samples: Input<SampleSet>,
    } {
        /// Unbiased: (albedo/pi) mean(L cos / pdf); Seed: the seed's formula exactly
        pub estimator: Estimator = Estimator::Unbiased,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new(
        "RelightSphere",
        "shading",
        2,
        "Relight a diffuse sphere with an environment through shared light samples",
    )
    .output("image", OutputType::Fixed(IMAGE_T), "the relit sphere")
    .size(|_, p: RelightParams<Check>| Some((p.size as u64, p.size as u64)))
    .check(check_grid)
    .code_hash(crate::op_code_hash!())
    .eval(eval)
}

/// The integral of the map's Rec. 709 luminance over the sphere: sum of Y * texel solid angle.
pub fn luminance_integral(env: &Image) -> f64 {
    (0..env.height)
        .map(|y| {
            let d_omega = latlong::texel_solid_angle(y, env.width, env.height);
            let row: f64 = (0..env.width).map(|x| rec709(env.rgb(x, y))).filter(|v| v.is_finite()).sum();
            row * d_omega
        })
        .sum()
}

fn eval(ctx: &mut OpContext, p: RelightParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, "env", p.env.width, p.env.height);
    let estimator = p.estimator;
    let view = sphere_view(p.size, p.view);
    let image = relight_shared(&p.env, &p.samples, p.size, p.albedo.0, view.view_dir(), estimator)?;
    Ok(Value::new(image))
}

fn check_weight(light: &LightSample, x: usize, y: usize, rgb: [f32; 3], pdf: f32) -> Result<(), OpError> {
    if light.weight.iter().any(|w| !w.is_finite()) {
        return Err(OpError::Invalid(format!(
            "texel ({x}, {y}) gives a non-finite light weight {:?} (radiance {rgb:?}, pdf {pdf})",
            light.weight
        )));
    }
    Ok(())
}

/// Lights for samples drawn at texel centres of a distribution over a grid coarser than `env`
/// (e.g. a distribution built from a downsized map). A point lookup at the coarse centre would
/// only ever see those directions (and miss a small sun entirely); instead each sample of coarse
/// texel T, drawn with probability `P_T = pdf * dOmega_T`, becomes the env texels t inside T:
///
/// - `Unbiased`: weight `L_t / (P_T / dOmega_t)`, so the sample contributes
///   `sum_t L_t max(n.d_t, 0) dOmega_t / P_T`, whose expectation over T is exactly the sum over
///   every env texel that `ReferenceSphere` computes.
/// - `Seed`: the seed's `V = rgb / |rgb|` per texel, weighted by the texel's share of T's
///   luminance `Y_t dOmega_t / sum_T Y dOmega`, which is what drawing from the env's own
///   distribution conditioned on T gives in expectation.
///
/// The env's size must be an integer multiple of the grid's (any other ratio would split env
/// texels between coarse texels); otherwise the operator refuses with the sizes.
fn spread_coarse_samples(
    env: &Image,
    set: &SampleSet,
    estimator: Estimator,
) -> Result<Vec<(u32, LightSample)>, OpError> {
    let (sw, sh) = (set.width as usize, set.height as usize);
    if sw == 0 || sh == 0 || !env.width.is_multiple_of(sw) || !env.height.is_multiple_of(sh) {
        return Err(OpError::Invalid(format!(
            "the samples come from a distribution over a {sw}x{sh} map but env is {}x{}: build the distribution \
             from env, or from a Resize of it by an integer factor",
            env.width, env.height
        )));
    }
    let (rx, ry) = (env.width / sw, env.height / sh);
    let mut lights = Vec::with_capacity(set.samples.len() * rx * ry);
    let mut block: Vec<(usize, usize, f64)> = Vec::with_capacity(rx * ry);
    for s in &set.samples {
        let (cx, cy) = (s.x as usize, s.y as usize);
        let probability = s.pdf as f64 * latlong::texel_solid_angle(cy, sw, sh);
        block.clear();
        for y in cy * ry..(cy + 1) * ry {
            let d_omega = latlong::texel_solid_angle(y, env.width, env.height);
            for x in cx * rx..(cx + 1) * rx {
                block.push((x, y, d_omega));
            }
        }
        let luminance_total: f64 = match estimator {
            Estimator::Seed => block.iter().map(|&(x, y, dw)| light_luminance(env.rgb(x, y)) * dw).sum(),
            Estimator::Unbiased => 0.0,
        };
        for &(x, y, d_omega) in &block {
            let rgb = env.rgb(x, y);
            let d = latlong::texel_direction(x, y, env.width, env.height).map(|c| c as f32);
            let pdf = (probability / d_omega) as f32;
            let light = match estimator {
                Estimator::Unbiased => LightSample::unbiased(d, rgb, pdf),
                Estimator::Seed => {
                    let share =
                        if luminance_total > 0.0 { light_luminance(rgb) * d_omega / luminance_total } else { 0.0 };
                    let mut l = LightSample::seed(d, rgb);
                    l.weight = l.weight.map(|w| (w as f64 * share) as f32);
                    l
                }
            };
            check_weight(&light, x, y, rgb, pdf)?;
            lights.push(((y * env.width + x) as u32, light));
        }
    }
    Ok(lights)
}

/// Rec. 709 luminance as a light's share: NaN, infinite and negative values count as 0.
fn light_luminance(rgb: [f32; 3]) -> f64 {
    let y = rec709(rgb);
    if y.is_finite() && y > 0.0 {
        y
    } else {
        0.0
    }
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
    // Samples drawn at the texel centres of a distribution over a coarser grid: spread each
    // over the env texels its coarse texel covers (below), which keeps the estimate exact.
    let lights = if !same_grid && set.luminance_integral.is_some() {
        spread_coarse_samples(env, set, estimator)?
    } else {
        let mut lights: Vec<(u32, LightSample)> = Vec::with_capacity(set.samples.len());
        for s in &set.samples {
            let (x, y) = if same_grid {
                (s.x as usize, s.y as usize)
            } else {
                // Continuous directions (a Phong lobe): a point lookup is the estimator.
                latlong::texel_of_direction([s.dir[0] as f64, s.dir[1] as f64, s.dir[2] as f64], env.width, env.height)
            };
            let rgb = env.rgb(x, y);
            let light = match estimator {
                Estimator::Seed => LightSample::seed(s.dir, rgb),
                Estimator::Unbiased => LightSample::unbiased(s.dir, rgb, s.pdf),
            };
            check_weight(&light, x, y, rgb, s.pdf)?;
            lights.push(((y * env.width + x) as u32, light));
        }
        lights
    };
    let merged = merge_duplicates(&lights);
    if let Some(l) = merged.iter().find(|l| l.weight.iter().any(|w| !w.is_finite())) {
        return Err(OpError::Invalid(format!(
            "samples merged on one texel (direction {:?}) sum to a weight beyond f32 range: the map's radiance over pdf overflows",
            l.dir
        )));
    }
    // The seed's formula scales by the luminance integral of the distribution the samples were
    // drawn from (carried by the samples: the distribution may be over another resolution or
    // another map than `env`); samples from no map (a Phong lobe) fall back to `env`'s. Only the
    // seed's formula needs it (a full pass over the map).
    let integral = match estimator {
        Estimator::Seed => set.luminance_integral.unwrap_or_else(|| luminance_integral(env)),
        Estimator::Unbiased => 0.0,
    };
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

/// Samples drawn from a distribution over another grid are spread over the env's texels, which
/// needs the env to be an integer multiple of that grid: refused here when both sizes are known
/// before running (`Sample` knows its distribution's grid; a Phong lobe has none).
fn check_grid(_: &CheckContext, p: RelightParams<Check>) -> Result<(), CheckProblem> {
    if let (Some((ew, eh)), Some((sw, sh))) = (p.env.size, p.samples.size) {
        if (ew, eh) != (sw, sh) && (sw == 0 || sh == 0 || ew % sw != 0 || eh % sh != 0) {
            return Err(CheckProblem::at(
                "samples",
                format!(
                    "the samples come from a distribution over a {sw}x{sh} map but env is {ew}x{eh}: build the \
                     distribution from env, or from a Resize of it by an integer factor"
                ),
            ));
        }
    }
    Ok(())
}
