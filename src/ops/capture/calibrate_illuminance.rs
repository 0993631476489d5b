//! `CalibrateIlluminance(env, lux)`: scales a lat-long map so that the illuminance it gives a
//! surface facing up (+Y) equals a measured value, as HDRI libraries calibrate to a lux meter held
//! level at the capture point (with L in nits the map's illuminance is in lux).
//!
//! `E = integral over the upper hemisphere of Y(omega) cos(theta) d omega`, each row's
//! cos-weighted solid angle in closed form, `(2 pi / W) (sin^2 t1 - sin^2 t0) / 2`, the row that
//! straddles the horizon clipped at pi / 2 (`maths::capture::illuminance`), Y the Rec. 709
//! luminance. Every channel but alpha is multiplied by `s = lux / E` (rounded to f32), so a
//! constant map L becomes exactly `lux / pi` (E = pi L to 1e-12 relative in f64, tested).
//!
//! Port `metrics`: `scale` (s), `illuminance_before` (E) and `illuminance_after` (E of the
//! output, `lux` up to f32 rounding). `lux <= 0` is a pipeline error; a map with a NaN or
//! infinite texel, or whose upper hemisphere gives no positive illuminance, a run error; a map
//! that is not 2:1 a warning.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::capture::illuminance::{scale_colour, upward_illuminance};
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::{Image, Metrics};

crate::params! {
    pub struct CalibrateIlluminanceParams {
        /// the lat-long map to calibrate
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
        /// the measured illuminance on a surface facing up, lux (> 0)
        pub lux: f64,
    }
}

const IMAGE: Port<Image> = Port::new("image");
const METRICS: Port<Metrics> = Port::new("metrics");

pub fn spec() -> OpSpec {
    Op::new(
        "CalibrateIlluminance",
        1,
        "Scale a lat-long map so that its illuminance on an upward-facing surface equals a measured lux value",
        eval,
    )
    .output_like(IMAGE, |p| p.env, "the scaled map (alpha unchanged)")
    .port(METRICS, METRICS_T, "scale, illuminance_before, illuminance_after")
    .size(|_, p| p.env.size)
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: CalibrateIlluminanceParams<Check>) -> Result<(), CheckProblem> {
    if !(p.lux > 0.0 && p.lux.is_finite()) {
        return Err(CheckProblem::at(
            CalibrateIlluminanceParams::lux,
            format!("lux must be a positive, finite illuminance, not {}", p.lux),
        ));
    }
    Ok(())
}

fn eval(ctx: &mut OpContext, p: CalibrateIlluminanceParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    check_finite(&p.env)?;
    let before = upward_illuminance(&p.env);
    if !(before > 0.0 && before.is_finite()) {
        return Err(OpError::Invalid(format!(
            "the map's upper hemisphere gives an illuminance of {before}: only a positive illuminance can be scaled to {} lux",
            p.lux
        )));
    }
    let scale = (p.lux / before) as f32;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(OpError::Invalid(format!(
            "scaling an illuminance of {before:e} to {:e} lux needs a factor outside the f32 range",
            p.lux
        )));
    }
    let mut out = p.env.take();
    scale_colour(&mut out, scale);
    if out.data.iter().any(|v| !v.is_finite()) {
        return Err(OpError::Invalid(format!(
            "scaling the map by {scale:e} to {} lux overflows f32 at its brightest texels",
            p.lux
        )));
    }
    let after = upward_illuminance(&out);
    let metrics = Metrics {
        fields: vec![
            ("scale".into(), scale as f64),
            ("illuminance_before".into(), before),
            ("illuminance_after".into(), after),
        ],
    };
    Ok(Outputs::new().port(IMAGE, out).port(METRICS, metrics))
}
