//! `Tonemap(image, curve: Aces, exposure: 0)`: scene-referred linear radiance to display-referred
//! linear values in [0, 1], ready for `Save` to an 8-bit PNG (which applies the sRGB curve).
//!
//! First the exposure, x = v * 2^exposure, then the curve, per sample:
//!
//! - **Reinhard**: f(x) = x / (1 + x) (Reinhard et al. 2002, "Photographic Tone Reproduction for
//!   Digital Images", eq. 3, applied per channel). f(1) = 1/2; f(x) < 1 for every finite x.
//! - **Aces**: Krzysztof Narkowicz's fit of the ACES RRT + ODT (Rec. 709, gamma removed),
//!   f(x) = clamp(x (a x + b) / (x (c x + d) + e), 0, 1) with a = 2.51, b = 0.03, c = 2.43,
//!   d = 0.59, e = 0.14 ("ACES Filmic Tone Mapping Curve", 2016,
//!   <https://knarkowicz.wordpress.com/2016/01/06/aces-filmic-tone-mapping-curve/>; max fit error
//!   0.0138). His data is pre-exposed so that 1 maps to about 0.8 (exactly 2.54 / 3.16 = 0.8038);
//!   for the original ACES scale, use exposure log2(0.6) = -0.737.
//! - **Agx**: Benjamin Wrensch's "Minimal AgX Implementation" (iolite engine, 2023, MIT licence,
//!   <https://iolite-engine.com/blog_posts/minimal_agx_implementation>), a fit of Troy Sobotka's
//!   AgX (<https://github.com/sobotka/AgX>). On linear Rec. 709 RGB:
//!   1. inset: v = M rgb, M below (rows nearly sum to 1, so grey stays nearly grey);
//!   2. log encoding: u = (clamp(log2 v, -12.47393, 4.026069) + 12.47393) / 16.499999;
//!   3. the sigmoid, his 6th-order polynomial (mean squared error 3.67e-6):
//!      s(u) = 15.5 u^6 - 40.14 u^5 + 31.96 u^4 - 6.868 u^3 + 0.4298 u^2 + 0.1191 u - 0.00232;
//!   4. outset: M^-1 s, then the 2.2 power of his "agxEotf" (display encoding to linear), after
//!      clamping to [0, 1].
//!
//!   Channels named R, G and B are mapped together (the inset mixes them); any other channel c
//!   (e.g. a luminance field) is mapped as the grey (c, c, c), taking the mean of the three
//!   results. AgX(0) = 0, and grey saturates at (s(1) (row sum of M^-1))^2.2, about 0.997.
//!
//! **Alpha**: in an image of two or more channels, the channel named `A` passes through
//! unchanged (neither exposed nor mapped).
//!
//! **Awkward values**: NaN and negatives count as 0, and values above 1e30 as 1e30 (where every
//! curve has saturated), so the output is always finite and in [0, 1].

use rayon::prelude::*;

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::choice! {
    /// The tone curve.
    pub enum Curve { Reinhard, Aces, Agx }
}

crate::params! {
    pub struct TonemapParams {
        /// linear radiance
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// Reinhard x/(1+x), Aces (Narkowicz's fit) or Agx (Wrensch's minimal AgX)
        pub curve: Curve = Curve::Aces,
        /// exposure in stops, applied before the curve (+1 doubles)
        #[range(-126.0, 126.0)]
        pub exposure: f64 = 0.0,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Tonemap", 1, "Exposure then a tone curve (Reinhard, ACES, AgX) to display-linear [0, 1]", eval)
        .output_like("image", |p| p.image, "display-referred linear values in [0, 1]; alpha unchanged")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .into()
}

/// NaN and negatives -> 0, huge values -> 1e30.
#[inline]
fn sanitize(x: f64) -> f64 {
    if x > 0.0 {
        x.min(1e30)
    } else {
        0.0
    }
}

/// Reinhard's x / (1 + x).
pub fn reinhard(x: f64) -> f64 {
    let x = sanitize(x);
    x / (1.0 + x)
}

/// Narkowicz's ACES fit.
pub fn aces(x: f64) -> f64 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    let x = sanitize(x);
    (x * (a * x + b) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

/// AgX inset matrix, row-major (Wrensch's GLSL `mat3` lists it column by column).
const AGX_INSET: [[f64; 3]; 3] = [
    [0.842479062253094, 0.0784335999999992, 0.0792237451477643],
    [0.0423282422610123, 0.878468636469772, 0.0791661274605434],
    [0.0423756549057051, 0.0784336, 0.879142973793104],
];
/// Its inverse, the outset, row-major.
const AGX_OUTSET: [[f64; 3]; 3] = [
    [1.19687900512017, -0.0980208811401368, -0.0990297440797205],
    [-0.0528968517574562, 1.15190312990417, -0.0989611768448433],
    [-0.0529716355144438, -0.0980434501171241, 1.15107367264116],
];
const AGX_MIN_EV: f64 = -12.47393;
const AGX_MAX_EV: f64 = 4.026069;

fn mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// Wrensch's 6th-order fit of the AgX sigmoid.
fn agx_contrast(u: f64) -> f64 {
    let (u2, u4) = (u * u, u * u * u * u);
    15.5 * u4 * u2 - 40.14 * u4 * u + 31.96 * u4 - 6.868 * u2 * u + 0.4298 * u2 + 0.1191 * u - 0.00232
}

/// Minimal AgX of a linear Rec. 709 triple, to display-linear [0, 1].
pub fn agx(rgb: [f64; 3]) -> [f64; 3] {
    let v = mul(&AGX_INSET, rgb.map(sanitize));
    let s = v.map(|c| {
        // log2 of 0 is -inf, which the clamp sends to the bottom of the range.
        let ev = c.max(f64::MIN_POSITIVE).log2().clamp(AGX_MIN_EV, AGX_MAX_EV);
        agx_contrast((ev - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV))
    });
    mul(&AGX_OUTSET, s).map(|c| c.clamp(0.0, 1.0).powf(2.2))
}

/// Tone-maps `img` in place (alpha untouched).
pub fn tonemap(img: &mut Image, curve: Curve, exposure: f64) {
    let gain = exposure.exp2();
    let c = img.channels;
    let alpha = if c > 1 { img.channel_index("A") } else { None };
    let rgb = match (img.channel_index("R"), img.channel_index("G"), img.channel_index("B")) {
        (Some(r), Some(g), Some(b)) if curve == Curve::Agx => Some([r, g, b]),
        _ => None,
    };
    img.data.par_chunks_exact_mut(c).for_each(|px| {
        for (k, v) in px.iter_mut().enumerate() {
            if Some(k) == alpha || rgb.is_some_and(|i| i.contains(&k)) {
                continue;
            }
            let x = *v as f64 * gain;
            *v = match curve {
                Curve::Reinhard => reinhard(x),
                Curve::Aces => aces(x),
                Curve::Agx => agx([x; 3]).iter().sum::<f64>() / 3.0,
            } as f32;
        }
        if let Some(i) = rgb {
            let out = agx(i.map(|k| px[k] as f64 * gain));
            for (k, v) in i.into_iter().zip(out) {
                px[k] = v as f32;
            }
        }
    });
}

fn eval(_: &mut OpContext, p: TonemapParams) -> Result<Value, OpError> {
    let mut img = p.image.take();
    tonemap(&mut img, p.curve, p.exposure);
    Ok(Value::new(img))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reinhard_and_aces_closed_forms() {
        assert_eq!(reinhard(1.0), 0.5);
        assert_eq!(reinhard(3.0), 0.75);
        assert_eq!(reinhard(0.0), 0.0);
        assert_eq!(aces(0.0), 0.0);
        // Narkowicz: "1 on input maps to ~0.8".
        assert!((aces(1.0) - 2.54 / 3.16).abs() < 1e-15);
        assert_eq!(aces(1e6), 1.0); // a / c = 1.033 > 1, clamped
        for f in [reinhard, aces] {
            assert_eq!(f(f64::NAN), 0.0);
            assert_eq!(f(-5.0), 0.0);
            let top = f(f64::INFINITY);
            assert!(top.is_finite() && top <= 1.0 && top > 0.99);
        }
    }

    #[test]
    fn agx_matrices_are_inverse_and_the_curve_is_bounded_and_monotonic() {
        let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for (i, row) in id.iter().enumerate() {
            let back = mul(&AGX_OUTSET, mul(&AGX_INSET, *row));
            for (j, &v) in back.iter().enumerate() {
                assert!((v - id[i][j]).abs() < 1e-6, "{back:?}");
            }
        }
        assert_eq!(agx([0.0; 3]), [0.0; 3]);
        // Saturation: s(1) is the sum of the coefficients, times the outset's row sums, ^2.2.
        let s1: f64 = 15.5 - 40.14 + 31.96 - 6.868 + 0.4298 + 0.1191 - 0.00232;
        let top = agx([1e30; 3]);
        for (k, row) in AGX_OUTSET.iter().enumerate() {
            assert!((top[k] - (s1 * row.iter().sum::<f64>()).powf(2.2)).abs() < 1e-12);
        }
        assert!(top.iter().all(|v| (v - 0.997).abs() < 1e-3), "{top:?}");
        let mut last = -1.0;
        for i in 0..=400 {
            let x = (i as f64 / 400.0 * 20.0 - 14.0).exp2(); // 2^-14 .. 2^6
            let y = agx([x; 3]);
            assert!(y.iter().all(|v| (0.0..=1.0).contains(v)));
            assert!((y[0] - y[1]).abs() < 1e-3 && (y[2] - y[1]).abs() < 1e-3, "grey stays grey: {y:?}");
            assert!(y[1] >= last, "monotonic at {x}");
            last = y[1];
        }
    }

    #[test]
    fn exposure_comes_first_and_alpha_passes_through() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let mut img = Image::with_names(1, 1, names, vec![0.5, 1.5, f32::NAN, 0.25]);
        tonemap(&mut img, Curve::Reinhard, 1.0);
        assert_eq!(img.data, vec![0.5, 0.75, 0.0, 0.25]);
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let mut img = Image::with_names(1, 1, names, vec![0.18, 0.18, 0.18, 0.5]);
        tonemap(&mut img, Curve::Agx, 0.0);
        let want = agx([0.18f32 as f64; 3]);
        assert_eq!(img.data, vec![want[0] as f32, want[1] as f32, want[2] as f32, 0.5]);
        // A luminance field is mapped as grey.
        let mut y = Image::from_vec(1, 1, 1, vec![0.18]);
        tonemap(&mut y, Curve::Agx, 0.0);
        assert!((y.data[0] as f64 - want.iter().sum::<f64>() / 3.0).abs() < 1e-7);
    }
}
