//! A diffuse sphere relit through light samples shared by every pixel, as in the seed
//! (`RelightSphere`'s work).
//!
//! - `Unbiased`: Lo(n) = (albedo/pi) * (1/N) * sum_j L(w_j) max(n.w_j, 0) / pdf(w_j), the Monte
//!   Carlo estimate of (albedo/pi) * integral of L(w) max(n.w, 0) dw. Its expectation is the
//!   exact sum over texels that `maths::render::reference` computes.
//! - `Seed`: the seed's formula exactly, L = (integral of L dw / N) * sum_j (1/pi) max(cos, 0) V_j
//!   with V_j = rgb_j / |rgb_j| (times albedo). The integral is that of the Rec. 709 luminance
//!   of the map the samples' distribution was built from (`SampleSet::luminance_integral`), so
//!   samples drawn from a distribution over another resolution scale correctly. Against
//!   `Unbiased` with a luminance-proportional pdf (where L/pdf = rgb/Y * integral), it replaces
//!   rgb/Y by rgb/|rgb|: for grey light |rgb| = sqrt(3) Y, so the seed is sqrt(3) = 1.73x too
//!   dark, and its hue shifts towards the dominant channel.
//!
//! Samples that land on one texel are merged into one light of summed weight (exact: every
//! pixel sees the same direction), pixels off the disc cost nothing, and samples behind a
//! pixel's surface add nothing (max(cos, 0)).

use crate::colour::rec709_luminance as rec709;
use crate::geometry::latlong;
use crate::maths::render::relight::{merge_duplicates, relight, Estimator, LightSample, SphereView};
use crate::values::Image;
use crate::values::SampleSet;

/// Why a relit sphere cannot be computed: each names the value that is out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SharedRelightError {
    /// A sample's radiance over its pdf is not finite.
    #[error("texel ({x}, {y}) gives a non-finite light weight {weight:?} (radiance {rgb:?}, pdf {pdf})")]
    NonFiniteWeight { x: usize, y: usize, weight: [f32; 3], rgb: [f32; 3], pdf: f32 },
    /// The samples' grid does not divide the map's (see [`relight_sphere`]).
    #[error(
        "the samples come from a distribution over a {samples_width}x{samples_height} map but env is \
         {env_width}x{env_height}: build the distribution from env, or from a Resize of it by an integer factor"
    )]
    GridMismatch { samples_width: usize, samples_height: usize, env_width: usize, env_height: usize },
    /// Samples merged on one texel sum beyond f32.
    #[error(
        "samples merged on one texel (direction {dir:?}) sum to a weight beyond f32 range: the map's radiance over \
         pdf overflows"
    )]
    MergedWeightOverflow { dir: [f32; 3] },
    /// The estimator's scale (albedo, count, luminance integral) is beyond f32.
    #[error("the estimator's scale {scale:?} is beyond f32 range")]
    ScaleOverflow { scale: [f32; 3] },
    /// A relit pixel is beyond f32.
    #[error("relit radiance at pixel ({x}, {y}) overflows f32 (largest 3.4e38): scale the map down with Exposure")]
    RadianceOverflow { x: usize, y: usize },
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

fn check_weight(light: &LightSample, x: usize, y: usize, rgb: [f32; 3], pdf: f32) -> Result<(), SharedRelightError> {
    if light.weight.iter().any(|w| !w.is_finite()) {
        return Err(SharedRelightError::NonFiniteWeight { x, y, weight: light.weight, rgb, pdf });
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
///   every env texel that `maths::render::reference` computes.
/// - `Seed`: the seed's `V = rgb / |rgb|` per texel, weighted by the texel's share of T's
///   luminance `Y_t dOmega_t / sum_T Y dOmega`, which is what drawing from the env's own
///   distribution conditioned on T gives in expectation.
///
/// The env's size must be an integer multiple of the grid's (any other ratio would split env
/// texels between coarse texels); otherwise this refuses with the sizes.
fn spread_coarse_samples(
    env: &Image,
    set: &SampleSet,
    estimator: Estimator,
) -> Result<Vec<(u32, LightSample)>, SharedRelightError> {
    let (sw, sh) = (set.width as usize, set.height as usize);
    if sw == 0 || sh == 0 || !env.width.is_multiple_of(sw) || !env.height.is_multiple_of(sh) {
        return Err(SharedRelightError::GridMismatch {
            samples_width: sw,
            samples_height: sh,
            env_width: env.width,
            env_height: env.height,
        });
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

/// A `size` x `size` diffuse sphere of `albedo` seen from `view_dir`, lit by `set`'s samples of
/// `env` under `estimator`. Samples drawn at the texel centres of a distribution over a coarser
/// grid (an integer fraction of `env`'s) are spread over the env texels each covers
/// ([`spread_coarse_samples`]); samples with continuous directions (a Phong lobe) look up the
/// texel they point at.
pub fn relight_sphere(
    env: &Image,
    set: &SampleSet,
    size: usize,
    albedo: [f64; 3],
    view_dir: [f64; 3],
    estimator: Estimator,
) -> Result<Image, SharedRelightError> {
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
        return Err(SharedRelightError::MergedWeightOverflow { dir: l.dir });
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
        return Err(SharedRelightError::ScaleOverflow { scale });
    }
    let image = relight(&SphereView::new(size, view_dir), &merged, scale);
    if let Some(i) = image.data.iter().position(|v| !v.is_finite()) {
        let px = i / 3;
        return Err(SharedRelightError::RadianceOverflow { x: px % size, y: px / size });
    }
    Ok(image)
}
