//! `MeanLightVector(image)` -> `metrics` `x, y, z, length`: how directional a lat-long map's
//! light is.
//!
//! `v = sum_t Y_t dOmega_t d_t / sum_t Y_t dOmega_t`, with `Y` the Rec. 709 luminance (a
//! one-channel field is its own luminance), `dOmega` the midpoint solid angle
//! `(2 pi / W)(pi / H) sin(theta)` and `d` the texel centre's direction (hdrflow's convention:
//! +Y up, the centre column faces -Z, +X at 3/4 of the width). For a non-negative map
//! `length = |v|` is in [0, 1]: 1 for light from a single direction, 0 for light balanced on
//! every side (a constant map). `x, y, z` is the luminance-weighted mean direction, not
//! normalised (its direction is `v / length`).
//!
//! Closed forms the tests check: a single lit texel gives its own direction, length 1 (to
//! 1e-12); a constant map gives length 0 to 1e-12 (the grid is symmetric, so the midpoint rule
//! cancels exactly); the upper hemisphere gives (0, 1/2, 0) up to the midpoint rule's
//! O(1/H^2) (relative 2e-3 at H = 32); `a + b.d` gives `b / 3a`. A luminance integral that
//! is not positive (a black map) and NaN or infinite texels are errors.

use glam::DVec3;
use rayon::prelude::*;

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::{Image, Metrics};

crate::params! {
    pub struct MeanLightVectorParams {
        /// the lat-long map (RGB, or one channel)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "MeanLightVector",
        1,
        "The luminance-weighted mean light direction of a lat-long map (x, y, z) and its length in [0, 1]",
        eval,
    )
    .output("metrics", METRICS_T, "x, y, z, length")
    .into()
}

/// `(sum Y dOmega d, sum Y dOmega)` (rows in parallel, summed in order: deterministic).
fn moments(img: &Image) -> (DVec3, f64) {
    let (w, h, c) = (img.width, img.height, img.channels);
    let rows: Vec<(DVec3, f64)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let (mut v, mut s) = (DVec3::ZERO, 0.0f64);
            if c == 0 {
                return (v, s);
            }
            for (x, px) in img.row(y).chunks_exact(c).enumerate() {
                let lum = if c >= 3 { crate::colour::rec709_luminance([px[0], px[1], px[2]]) } else { px[0] as f64 };
                v += lum * DVec3::from(latlong::texel_direction(x, y, w, h));
                s += lum;
            }
            let d_omega = latlong::texel_solid_angle(y, w, h);
            (v * d_omega, s * d_omega)
        })
        .collect();
    rows.iter().fold((DVec3::ZERO, 0.0), |(v, s), (rv, rs)| (v + *rv, s + rs))
}

/// The mean light vector of the module documentation.
pub fn mean_light_vector(img: &Image) -> Result<[f64; 3], String> {
    let (v, s) = moments(img);
    if !(s > 0.0) {
        return Err(format!("the map's luminance integral is {s:e}, not positive: it has no mean light direction"));
    }
    Ok((v / s).to_array())
}

fn eval(ctx: &mut OpContext, p: MeanLightVectorParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.image);
    check_finite(&p.image)?;
    let [x, y, z] = mean_light_vector(&p.image).map_err(OpError::Invalid)?;
    let length = DVec3::new(x, y, z).length();
    let fields = [("x", x), ("y", y), ("z", z), ("length", length)];
    Ok(Value::new(Metrics { fields: fields.iter().map(|(n, v)| (n.to_string(), *v)).collect() }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_texel_constant_hemisphere_and_linear() {
        let (w, h) = (64, 32);
        for (tx, ty) in [(0, 0), (10, 5), (47, 16), (63, 31)] {
            let mut img = Image::new(w, h, 3);
            img.pixel_mut(tx, ty).copy_from_slice(&[5.0, 3.0, 1.0]);
            let v = mean_light_vector(&img).unwrap();
            let d = latlong::texel_direction(tx, ty, w, h);
            assert!((0..3).all(|k| (v[k] - d[k]).abs() < 1e-12), "{v:?} vs {d:?}");
            assert!((DVec3::from(v).length() - 1.0).abs() < 1e-12);
        }
        let constant = Image::from_fn_rgb(w, h, |_, _| [2.0, 2.0, 2.0]);
        let v = mean_light_vector(&constant).unwrap();
        assert!(DVec3::from(v).length() < 1e-12, "{v:?}");
        // Upper hemisphere: int_0^{pi/2} cos sin / int_0^{pi/2} sin = 1/2, along +Y; the error
        // shrinks as 1/H^2.
        let mut errors = Vec::new();
        for h in [32usize, 64, 128] {
            let img = Image::from_fn_rgb(2 * h, h, |_, y| if y < h / 2 { [1.0; 3] } else { [0.0; 3] });
            let v = mean_light_vector(&img).unwrap();
            assert!(v[0].abs() < 1e-12 && v[2].abs() < 1e-12, "{v:?}");
            errors.push((v[1] - 0.5).abs() / 0.5);
        }
        assert!(errors[0] < 2e-3, "{errors:?}");
        assert!(errors[1] < errors[0] / 3.5 && errors[2] < errors[1] / 3.5, "{errors:?}");
        // L = a + b.d: int L d dOmega = (4 pi / 3) b, int L dOmega = 4 pi a, so v = b / (3 a).
        let (a, b) = (2.0, DVec3::new(0.3, -0.5, 0.9));
        let (w, h) = (256, 128);
        let img = Image::from_fn_rgb(w, h, |x, y| {
            let l = (a + b.dot(DVec3::from(latlong::texel_direction(x, y, w, h)))) as f32;
            [l, l, l]
        });
        let v = DVec3::from(mean_light_vector(&img).unwrap());
        let want = b / (3.0 * a);
        assert!((v - want).length() < 2e-4 * want.length(), "{v} vs {want}");
    }

    #[test]
    fn black_map_is_an_error() {
        let e = mean_light_vector(&Image::new(8, 4, 3)).unwrap_err();
        assert!(e.contains("not positive"), "{e}");
    }
}
