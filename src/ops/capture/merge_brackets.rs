//! `MergeBrackets(brackets, response, weight: Hat | Gaussian | NoiseOptimal = Hat, deghost:
//! None | Consistency = None)`: bracketed exposures merged into relative radiance.
//!
//! Per pixel and channel, the weighted mean in the linear domain of each frame's radiance
//! estimate `x(z) / t`, `x` the response (`CalibrateResponse`'s `curves`; without one the codes
//! are linear, `x(z) = z / mid`); the weights, the treatment of pixels clipped or black in every
//! frame, the frames' coverage masks and the consistency deghosting are
//! `maths::capture::merge`'s. Ports: `image` (RGB, relative radiance: the map up to one
//! global scale), `confidence` (the weights' sum per pixel, averaged over the channels),
//! `saturated` (1 where a channel is at the top code in every frame: such a channel holds the
//! shortest exposure's value, a lower bound) and `metrics`: `frames`, `saturated_fraction`,
//! `underexposed_fraction` (a channel at code 0 in every frame), `mean_confidence`,
//! `dropped_fraction` (frame-pixel pairs dropped by deghosting). `confidence` and `saturated`
//! are computed only when something in the run reads them (`OpContext::wants`): then the
//! merge's memory is the frames and the image. A response that is not
//! monotonic, or for another bit depth, and a single frame are errors. Tests
//! (`maths::capture::tests`): five 8-bit sRGB brackets two stops apart merge through
//! `CalibrateResponse` (Debevec, 70 samples) to within the 3% median relative error of
//! the map after the best scale (measured 1.3% to 2.7% on two maps; 0.8% with the true response).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::capture::merge::{merge_maps, Deghost, Maps, Weight};
use crate::maths::capture::response::Response;
use crate::values::brackets::Brackets;
use crate::values::ty::*;
use crate::values::{Curves, Image, Metrics};

crate::params! {
    pub struct MergeBracketsParams {
        /// the bracketed frames (at least 2)
        #[input(&[BRACKETS_T])]
        pub brackets: Input<Brackets>,
        /// the camera's response (CalibrateResponse); without it the codes are linear
        #[input(&[CURVES_T])]
        pub response: Option<Input<Curves>>,
        /// Hat (Debevec), Gaussian (Robertson) or NoiseOptimal (exposure-time, shot-noise optimal)
        pub weight: Weight = Weight::Hat,
        /// None, or Consistency: drop frames that disagree with the middle exposure beyond the noise
        pub deghost: Deghost = Deghost::None,
    }
}

const IMAGE: Port<Image> = Port::new("image");
const CONFIDENCE: Port<Image> = Port::new("confidence");
const SATURATED: Port<Image> = Port::new("saturated");
const METRICS: Port<Metrics> = Port::new("metrics");

pub fn spec() -> OpSpec {
    Op::new(
        "MergeBrackets",
        1,
        "Merge bracketed exposures into relative radiance (with confidence and the saturated mask)",
        eval,
    )
    .port(IMAGE, IMAGE_T, "relative radiance, RGB")
    .port(CONFIDENCE, SCALAR_T, "the sum of the frames' weights per pixel (mean over the channels)")
    .port(SATURATED, SCALAR_T, "1 where a channel is clipped in every frame (it holds the shortest exposure's value)")
    .port(METRICS, METRICS_T, "frames, saturated and underexposed fractions, mean confidence, dropped fraction")
    .into()
}

fn eval(ctx: &mut OpContext, p: MergeBracketsParams) -> Result<Outputs, OpError> {
    let b: &Brackets = &p.brackets;
    super::require_frames(b, 2)?;
    let response = match &p.response {
        None => Response::linear(b.bit_depth),
        Some(c) => {
            Response::from_curves(c, b.bit_depth).map_err(|e| OpError::Invalid(format!("input \"response\": {e}")))?
        }
    };
    // The per-pixel maps only when something reads them (the frames and the image are the
    // memory a merge cannot do without).
    let maps = Maps { confidence: ctx.wants(CONFIDENCE.name), saturated: ctx.wants(SATURATED.name) };
    let m = merge_maps(b, &response, p.weight, p.deghost, maps);
    let pixels = b.pixel_count().max(1) as f64;
    let metrics = Metrics {
        fields: vec![
            ("frames".into(), b.frames.len() as f64),
            ("saturated_fraction".into(), m.saturated_pixels as f64 / pixels),
            ("underexposed_fraction".into(), m.dark_pixels as f64 / pixels),
            ("mean_confidence".into(), m.confidence_sum / pixels),
            ("dropped_fraction".into(), m.dropped as f64 / (pixels * b.frames.len() as f64)),
        ],
    };
    let (w, h) = (b.width, b.height);
    let mut out = Outputs::new().port(IMAGE, Image::from_vec(w, h, 3, m.image)).port(METRICS, metrics);
    if maps.confidence {
        out = out.port(CONFIDENCE, Image::from_vec(w, h, 1, m.confidence));
    }
    if maps.saturated {
        out = out.port(SATURATED, Image::from_vec(w, h, 1, m.saturated));
    }
    Ok(out)
}
