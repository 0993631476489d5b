//! `ImageError(image, reference, mask: Sphere)`: error metrics of an image against a reference
//! of the same size (`maths::stats::error_metrics`): `pixels`, `values`, `rmse`, `relative_rmse`
//! (rmse / RMS of the reference), `mean_abs`, `max_abs`, `mean_error` (signed bias), `psnr`
//! (20 log10(max(reference) / rmse), capped at +-999 dB), `reference_rms`, `reference_max`.
//!
//! `mask`: `Sphere` keeps the pixels of the inscribed disc, those whose centre has
//! `sx^2 + sy^2 <= 1` with `sx = 2 (px + 0.5) / size - 1`, `sy = 1 - 2 (py + 0.5) / size`,
//! exactly the pixels `SphereView::normal_at` shades (images must be square); `All` keeps every
//! pixel.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{check_same_shape, CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

use crate::maths::render::relight::SphereView;
use crate::maths::stats::error_metrics::image_error;

crate::choice! {
    /// Which pixels count.
    pub enum Mask { Sphere, All }
}

crate::params! {
    pub struct ImageErrorParams {
        /// the image to measure
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// the reference, same size and channels
        #[input(ANY_IMAGE)]
        pub reference: Input<Image>,
        /// Sphere: the inscribed disc (the pixels a sphere renderer shades); All: every pixel
        pub mask: Mask = Mask::Sphere,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "ImageError",
        1,
        "Error metrics (RMSE, relative RMSE, mean/max abs, bias, PSNR) of an image against a reference",
        eval,
    )
    .output("metrics", METRICS_T, "the error metrics")
    .check(check)
    .into()
}

/// The image and the reference, when both sizes are known before running, must be equal.
fn check(_: &CheckContext, p: ImageErrorParams<Check>) -> Result<(), CheckProblem> {
    check_same_shape(p.image, p.reference)
}

/// The inscribed-disc mask of a `size` x `size` image: true where `SphereView::normal_at` is
/// `Some` (the view direction does not matter).
pub fn sphere_mask(size: usize) -> Vec<bool> {
    let view = SphereView::new(size, [0.0, 0.0, 1.0]);
    (0..size * size).map(|i| view.normal_at(i % size, i / size).is_some()).collect()
}

fn eval(_: &mut OpContext, p: ImageErrorParams) -> Result<Value, OpError> {
    let (image, reference) = (&*p.image, &*p.reference);
    let mask = match p.mask {
        Mask::Sphere => {
            if image.width != image.height {
                return Err(OpError::Invalid(format!(
                    "mask Sphere needs a square image, got {}x{} (use mask: All)",
                    image.width, image.height
                )));
            }
            Some(sphere_mask(image.width))
        }
        Mask::All => None,
    };
    let metrics = image_error(image, reference, mask.as_deref()).map_err(OpError::Invalid)?;
    Ok(Value::new(metrics))
}
