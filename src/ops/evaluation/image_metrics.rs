//! `ImageMetrics(pred, gt, mask)`: the lighting-estimation protocol's four metrics of a rendered
//! prediction against the render of the truth, `rmse`, `si_rmse`, `angular_error_deg` and
//! `norm_rmse`, with exactly the definitions of the protocol's `fast_rmse.py`
//! (`maths::stats::protocol_metrics`, which states each formula and where this differs from the
//! script: a black prediction's `si_rmse`, NaN pixels), plus `pixels` and `nonfinite_pixels`.
//!
//! The pixels: where `mask`'s first channel is > 0; without a mask, where `pred`'s alpha (`A`)
//! is > 0, as the script takes them from the render's transparent film; a `pred` without alpha and
//! no mask counts every pixel (a warning says so). Masked pixels holding NaN or infinity are
//! left out and counted (a warning gives the count), never averaged in.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{check_same_size, CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::stats::protocol_metrics::{protocol_metrics, Pixels};
use crate::values::ty::*;
use crate::values::{Image, Metrics};

crate::params! {
    pub struct ImageMetricsParams {
        /// the prediction's render (RGB or RGBA; its alpha is the mask when no mask is wired)
        #[input(&[IMAGE_T])]
        pub pred: Input<Image>,
        /// the ground truth's render, the size of pred
        #[input(&[IMAGE_T])]
        pub gt: Input<Image>,
        /// pixels to count: where the first channel is > 0 (an image or scalar field, the size of pred)
        #[input(ANY_IMAGE)]
        pub mask: Option<Input<Image>>,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "ImageMetrics",
        1,
        "The sphere protocol's rmse, si_rmse, angular_error_deg and norm_rmse (fast_rmse.py) of a render against the truth's",
        eval,
    )
    .output("metrics", METRICS_T, "rmse, si_rmse, angular_error_deg, norm_rmse, pixels, nonfinite_pixels")
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: ImageMetricsParams<Check>) -> Result<(), CheckProblem> {
    check_same_size(p.pred, p.gt)?;
    match p.mask {
        Some(mask) => check_same_size(p.pred, mask),
        None => Ok(()),
    }
}

fn eval(ctx: &mut OpContext, p: ImageMetricsParams) -> Result<Value, OpError> {
    let (pred, gt) = (&*p.pred, &*p.gt);
    let same = |a: &Image, b: &Image| (a.width, a.height) == (b.width, b.height);
    if !same(pred, gt) {
        return Err(OpError::Invalid(format!(
            "pred is {}x{} but gt is {}x{}: they must be the same size",
            pred.width, pred.height, gt.width, gt.height
        )));
    }
    for (name, img) in [("pred", pred), ("gt", gt)] {
        if img.channels < 3 {
            return Err(OpError::Invalid(format!("{name} has {} channels; the metrics need RGB", img.channels)));
        }
    }
    let mask: Vec<bool> = match (&p.mask, pred.channel_index("A")) {
        (Some(m), _) => {
            if !same(m, pred) {
                return Err(OpError::Invalid(format!(
                    "mask is {}x{} but pred is {}x{}: they must be the same size",
                    m.width, m.height, pred.width, pred.height
                )));
            }
            m.data.chunks_exact(m.channels).map(|px| px[0] > 0.0).collect()
        }
        (None, Some(a)) => pred.data.chunks_exact(pred.channels).map(|px| px[a] > 0.0).collect(),
        (None, None) => {
            ctx.warn("pred has no alpha channel and no mask is wired: every pixel counts");
            vec![true; pred.pixel_count()]
        }
    };
    let m = protocol_metrics(
        &Pixels { data: &pred.data, channels: pred.channels },
        &Pixels { data: &gt.data, channels: gt.channels },
        &mask,
    )
    .map_err(OpError::Invalid)?;
    if m.nonfinite_pixels > 0 {
        ctx.warn(format!(
            "{} masked pixels hold NaN or infinity and were left out (nonfinite_pixels)",
            m.nonfinite_pixels
        ));
    }
    let fields = [
        ("rmse", m.rmse),
        ("si_rmse", m.si_rmse),
        ("angular_error_deg", m.angular_error_deg),
        ("norm_rmse", m.norm_rmse),
        ("pixels", m.pixels as f64),
        ("nonfinite_pixels", m.nonfinite_pixels as f64),
    ];
    Ok(Value::new(Metrics { fields: fields.iter().map(|(n, v)| (n.to_string(), *v)).collect() }))
}
