//! `ImageError(image, reference, mask: Sphere)`: error metrics of an image against a reference
//! of the same size (`maths::error_metrics`): `pixels`, `values`, `rmse`, `relative_rmse`
//! (rmse / RMS of the reference), `mean_abs`, `max_abs`, `mean_error` (signed bias), `psnr`
//! (20 log10(max(reference) / rmse), capped at +-999 dB), `reference_rms`, `reference_max`.
//!
//! `mask`: `Sphere` keeps the pixels of the inscribed disc, those whose centre has
//! `sx^2 + sy^2 <= 1` with `sx = 2 (px + 0.5) / size - 1`, `sy = 1 - 2 (py + 0.5) / size`,
//! exactly the pixels `SphereView::normal_at` shades (images must be square); `All` keeps every
//! pixel.

use std::sync::Arc;

use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::maths::error_metrics::image_error;
use crate::maths::relight::SphereView;

pub static SPEC: OpSpec = OpSpec {
    name: "ImageError",
    category: "image",
    version: 1,
    doc: "Error metrics (RMSE, relative RMSE, mean/max abs, bias, PSNR) of an image against a reference",
    fields: &[
        FieldSpec::input("image", &[ValueType::Image, ValueType::ScalarField], "the image to measure"),
        FieldSpec::input(
            "reference",
            &[ValueType::Image, ValueType::ScalarField],
            "the reference, same size and channels",
        ),
        FieldSpec {
            name: "mask",
            kind: FieldKind::Choice(&["Sphere", "All"]),
            default: Default::Choice("Sphere"),
            doc: "Sphere: the inscribed disc (the pixels a sphere renderer shades); All: every pixel",
        },
    ],
    output: OutputType::Fixed(ValueType::Metrics),
    eval,
    content_key: None,
    check: None,
};

/// The inscribed-disc mask of a `size` x `size` image: true where `SphereView::normal_at` is
/// `Some` (the view direction does not matter).
pub fn sphere_mask(size: usize) -> Vec<bool> {
    let view = SphereView::new(size, [0.0, 0.0, 1.0]);
    (0..size * size).map(|i| view.normal_at(i % size, i / size).is_some()).collect()
}

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let image = ctx.image("image");
    let reference = ctx.image("reference");
    let mask = match ctx.params.text("mask") {
        "Sphere" => {
            if image.width != image.height {
                return Err(OpError::Invalid(format!(
                    "mask Sphere needs a square image, got {}x{} (use mask: All)",
                    image.width, image.height
                )));
            }
            Some(sphere_mask(image.width))
        }
        _ => None,
    };
    let metrics = image_error(image, reference, mask.as_deref()).map_err(OpError::Invalid)?;
    Ok(Value::Metrics(Arc::new(metrics)))
}
