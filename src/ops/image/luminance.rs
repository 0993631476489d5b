//! `Luminance(image, weights: Rec709)`: per-pixel luminance Y = wr*R + wg*G + wb*B.
//!
//! Weights: Rec709 (ITU-R BT.709 / sRGB primaries) 0.2126, 0.7152, 0.0722; Rec2020 (ITU-R
//! BT.2020) 0.2627, 0.6780, 0.0593; Mean (R+G+B)/3; Max max(R, G, B).

use rayon::prelude::*;

use crate::data::Image;
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};

pub static SPEC: OpSpec = OpSpec {
    name: "Luminance",
    category: "image",
    version: 1,
    doc: "Per-pixel luminance of an RGB image (a scalar field)",
    fields: &[
        FieldSpec::input("image", &[ValueType::Image, ValueType::ScalarField], "the RGB image"),
        FieldSpec {
            name: "weights",
            kind: FieldKind::Choice(&["Rec709", "Rec2020", "Mean", "Max"]),
            default: Default::Choice("Rec709"),
            doc: "channel weights: Rec709 (0.2126, 0.7152, 0.0722), Rec2020, Mean, Max",
        },
    ],
    output: OutputType::Fixed(ValueType::ScalarField),
    eval,
    content_key: None,
    check: None,
};

/// Luminance of an RGB triple under the named weights.
pub fn luminance(rgb: [f32; 3], weights: &str) -> f32 {
    let [r, g, b] = rgb;
    match weights {
        "Rec2020" => 0.2627 * r + 0.6780 * g + 0.0593 * b,
        "Mean" => (r + g + b) / 3.0,
        "Max" => r.max(g).max(b),
        _ => 0.2126 * r + 0.7152 * g + 0.0722 * b,
    }
}

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let img = ctx.image("image");
    if img.channels == 1 {
        return Ok(Value::Image(img.clone()));
    }
    let weights = ctx.params.text("weights");
    let data: Vec<f32> = img.data.par_chunks_exact(3).map(|p| luminance([p[0], p[1], p[2]], weights)).collect();
    Ok(Value::image(Image::from_vec(img.width, img.height, 1, data)))
}

#[cfg(test)]
mod tests {
    use super::luminance;

    #[test]
    fn rec709_white_is_one() {
        assert!((luminance([1.0, 1.0, 1.0], "Rec709") - 1.0).abs() < 1e-6);
        assert!((luminance([1.0, 1.0, 1.0], "Rec2020") - 1.0).abs() < 1e-6);
        assert_eq!(luminance([1.0, 4.0, 2.0], "Max"), 4.0);
    }
}
