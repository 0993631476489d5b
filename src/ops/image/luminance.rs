//! `Luminance(image, weights: Rec709)`: per-pixel luminance Y = wr*R + wg*G + wb*B.
//!
//! Weights: Rec709 (ITU-R BT.709 / sRGB primaries) 0.2126, 0.7152, 0.0722; Rec2020 (ITU-R
//! BT.2020) 0.2627, 0.6780, 0.0593; Mean (R+G+B)/3; Max max(R, G, B).

use rayon::prelude::*;

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::choice! {
    /// Channel weights for luminance.
    pub enum Weights { Rec709, Rec2020, Mean, Max }
}

crate::params! {
    pub struct LuminanceParams {
        /// the RGB image (a scalar field passes through)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// channel weights: Rec709 (0.2126, 0.7152, 0.0722), Rec2020 (0.2627, 0.6780, 0.0593), Mean, Max
        pub weights: Weights = Weights::Rec709,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Luminance", 1, "Per-pixel luminance of an RGB image (a scalar field)", eval)
        .output("luminance", SCALAR_T, "the luminance")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .into()
}

/// Luminance of an RGB triple under the named weights.
pub fn luminance(rgb: [f32; 3], weights: Weights) -> f32 {
    let [r, g, b] = rgb;
    match weights {
        Weights::Rec709 => crate::colour::rec709_luminance_f32(rgb),
        Weights::Rec2020 => 0.2627 * r + 0.6780 * g + 0.0593 * b,
        Weights::Mean => (r + g + b) / 3.0,
        Weights::Max => r.max(g).max(b),
    }
}

fn eval(_: &mut OpContext, p: LuminanceParams) -> Result<Value, OpError> {
    let img = &*p.image;
    if img.channels == 1 {
        return Ok(p.image.value().clone());
    }
    let c = img.channels;
    let data: Vec<f32> = img
        .data
        .par_chunks_exact(c)
        .map(|px| {
            // RGB first (then alpha or others); a grey-plus-alpha image is grey.
            let rgb = if c >= 3 { [px[0], px[1], px[2]] } else { [px[0]; 3] };
            luminance(rgb, p.weights)
        })
        .collect();
    Ok(Value::new(Image::from_vec(img.width, img.height, 1, data)))
}

#[cfg(test)]
mod tests {
    use super::{luminance, Weights};

    #[test]
    fn rec709_white_is_one() {
        assert!((luminance([1.0, 1.0, 1.0], Weights::Rec709) - 1.0).abs() < 1e-6);
        assert!((luminance([1.0, 1.0, 1.0], Weights::Rec2020) - 1.0).abs() < 1e-6);
        assert_eq!(luminance([1.0, 4.0, 2.0], Weights::Max), 4.0);
    }
}
