//! `SphericalGaussians(env, lobes: 12, iterations: 30, seed: 0)`: `lobes` spherical Gaussians
//! `a exp(lambda (mu . d - 1))` fitted to a lat-long map by solid-angle-weighted least squares
//! (`maths::fit::spherical_gaussians`: a matching-pursuit start on the residual's peaks, then rounds
//! of a Levenberg-Marquardt step on axes and sharpnesses and exact NNLS amplitudes).
//!
//! - Port `lobes`: the `sg` value, most energetic lobe first (axes in hdrflow's world
//!   coordinates: +Y up, the lat-long centre column faces -Z).
//! - Port `metrics`: `relative_rmse` (`sqrt(sum w (f - L)^2 / sum w f^2)` over the fit map's
//!   texels and channels), `iterations` (rounds that made progress; fewer than asked when a
//!   round changed nothing), `fit_width`, `fit_height` (the input's size, or 256 x 128 when it
//!   is larger: the fit runs on an energy-preserving resampled copy, whose texels hold means
//!   and are fitted with the lobes' means over them).
//!
//! `seed` (0: none) jitters each starting axis by a pseudo-random tangent offset of up to a
//! quarter of its lobe's width (SplitMix64 seeded with `seed`). The result is a pure function of the
//! map and the three fields (bit-identical across runs and thread counts). NaN or infinite
//! texels are an error; `lobes` outside [1, 256] is refused before anything runs.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::fit::spherical_gaussians::fit;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::SphericalGaussians;
use crate::values::{Image, Metrics};

crate::params! {
    pub struct SphericalGaussiansParams {
        /// the lat-long environment (linear RGB; alpha ignored)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// how many lobes
        #[range(1, 256)]
        pub lobes: usize = 12,
        /// rounds of (Levenberg-Marquardt step on axes and sharpness, NNLS amplitudes)
        #[range(0, 10000)]
        pub iterations: usize = 30,
        /// jitters the starting axes by up to a quarter of each lobe's width (0: no jitter)
        pub seed: u64 = 0,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const LOBES: Port<SphericalGaussians> = Port::new("lobes");
const METRICS: Port<Metrics> = Port::new("metrics");

pub fn spec() -> OpSpec {
    // Version 2: a map reduced to the fit size is fitted with the lobes' means over its texels
    // (issue 39), not their values at the texel centres.
    Op::new(
        "SphericalGaussians",
        2,
        "Spherical Gaussian lobes fitted to a lat-long map (solid-angle-weighted least squares, NNLS amplitudes)",
        eval,
    )
    .port(LOBES, SG_T, "the lobes (axis, sharpness, RGB amplitude), most energetic first")
    .port(METRICS, METRICS_T, "relative_rmse, iterations, fit_width, fit_height")
    .into()
}

fn eval(ctx: &mut OpContext, p: SphericalGaussiansParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let env = &*p.env;
    check_finite(env)?;
    let f = fit(env, p.lobes, p.iterations, p.seed);
    let metrics = Metrics {
        fields: vec![
            ("relative_rmse".into(), f.relative_rmse),
            ("iterations".into(), f.iterations as f64),
            ("fit_width".into(), f.fit_width as f64),
            ("fit_height".into(), f.fit_height as f64),
        ],
    };
    Ok(Outputs::new().port(LOBES, f.sg).port(METRICS, metrics))
}
