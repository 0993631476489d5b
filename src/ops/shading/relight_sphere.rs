//! `RelightSphere(env, samples, size, albedo, view, estimator: Unbiased)`: a diffuse sphere seen
//! orthographically from `view` = (theta, phi) in degrees, its silhouette inscribed in the
//! `size` x `size` image, black background, lit by the environment through the given samples,
//! shared by every pixel as in the seed.
//!
//! - `Unbiased`: (albedo/pi) * (1/N) * sum_j L(w_j) max(n.w_j, 0) / pdf(w_j), whose expectation
//!   is the exact sum over texels that `ReferenceSphere` computes.
//! - `Seed`: the seed's formula exactly, which replaces rgb/Y by rgb/|rgb| (sqrt(3) = 1.73x too
//!   dark under grey light).
//!
//! The formulas, the merging of samples on one texel and the spreading of samples drawn over a
//! coarser grid are in `maths::render::shared_relight`.

use super::sphere_view;
use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem};
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::render::relight::Estimator;
use crate::maths::render::shared_relight;
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
    Op::new("RelightSphere", 2, "Relight a diffuse sphere with an environment through shared light samples", eval)
        .output("image", IMAGE_T, "the relit sphere")
        .size(|_, p| Some((p.size as u64, p.size as u64)))
        .check(check_grid)
        .into()
}

fn eval(ctx: &mut OpContext, p: RelightParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let estimator = p.estimator;
    let view = sphere_view(p.size, p.view);
    let image = shared_relight::relight_sphere(&p.env, &p.samples, p.size, p.albedo.0, view.view_dir(), estimator)
        .map_err(|e| OpError::Invalid(e.to_string()))?;
    Ok(Value::new(image))
}

/// Samples drawn from a distribution over another grid are spread over the env's texels, which
/// needs the env to be an integer multiple of that grid: refused here when both sizes are known
/// before running (`Sample` knows its distribution's grid; a Phong lobe has none).
fn check_grid(_: &CheckContext, p: RelightParams<Check>) -> Result<(), CheckProblem> {
    if let (Some((ew, eh)), Some((sw, sh))) = (p.env.size, p.samples.size) {
        if (ew, eh) != (sw, sh) && (sw == 0 || sh == 0 || ew % sw != 0 || eh % sh != 0) {
            return Err(CheckProblem::at(
                RelightParams::samples,
                format!(
                    "the samples come from a distribution over a {sw}x{sh} map but env is {ew}x{eh}: build the \
                     distribution from env, or from a Resize of it by an integer factor"
                ),
            ));
        }
    }
    Ok(())
}
