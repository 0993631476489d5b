//! The illuminance a lat-long map gives a surface facing up (+Y), and the scale that makes it a
//! measured value: how HDRI makers calibrate a map to a lux meter held level at the capture point.
//!
//! `E = integral over the upper hemisphere of L(omega) cos(theta) d omega`, theta from +Y (lux
//! when L is in nits, cd/m^2). On a W x H lat-long map (`geometry::latlong`: row y spans polar
//! angles [pi y / H, pi (y + 1) / H]) each texel is taken as constant, and its cos-weighted solid
//! angle is integrated in closed form rather than by the midpoint rule:
//!
//! ```text
//! w_y = (2 pi / W) * integral_{t0}^{t1} cos(t) sin(t) dt = (2 pi / W) (sin^2 t1 - sin^2 t0) / 2
//! ```
//!
//! with `t1` clipped at pi / 2 (the row straddling the horizon, when H is odd, counts its upper
//! part) and rows below the horizon weighing 0. The weights telescope: a constant map L gives
//! `E = pi L` up to f64 rounding (a test checks 1e-12 relative for sizes from 2 x 1 to
//! 4096 x 2048, odd heights included), so the calibration scales a constant map exactly.
//! L is the Rec. 709 luminance (`crate::colour`) of the first three channels (one channel: the
//! value itself), summed in f64. The scale is `s = E_target / E`.

use std::f64::consts::{FRAC_PI_2, PI};

use rayon::prelude::*;

use crate::colour::rec709_luminance;
use crate::values::Image;

/// The cos-weighted solid angle of one texel of row `y` of a `width x height` lat-long map,
/// counting its part above the horizon only (module documentation).
pub fn row_weight(y: usize, width: usize, height: usize) -> f64 {
    let t0 = PI * y as f64 / height as f64;
    if t0 >= FRAC_PI_2 {
        return 0.0;
    }
    let t1 = (PI * (y + 1) as f64 / height as f64).min(FRAC_PI_2);
    let (s0, s1) = (t0.sin(), t1.sin());
    (2.0 * PI / width as f64) * (s1 * s1 - s0 * s0) / 2.0
}

/// The illuminance on an upward-facing surface, `sum_y w_y sum_x Y(x, y)` (module
/// documentation). NaN or infinite texels make it non-finite; callers check.
pub fn upward_illuminance(env: &Image) -> f64 {
    let (w, h) = (env.width, env.height);
    if w == 0 || h == 0 {
        return 0.0;
    }
    (0..h)
        .into_par_iter()
        .map(|y| {
            let weight = row_weight(y, w, h);
            if weight == 0.0 {
                return 0.0;
            }
            let row: f64 = (0..w)
                .map(|x| if env.channels == 1 { env.pixel(x, y)[0] as f64 } else { rec709_luminance(env.rgb(x, y)) })
                .sum();
            weight * row
        })
        .sum()
}

/// Multiplies every channel but an alpha (`Image::alpha_index`) by `scale`, in place.
pub fn scale_colour(img: &mut Image, scale: f32) {
    let c = img.channels.max(1);
    let alpha = img.alpha_index();
    img.data.par_chunks_mut(c).for_each(|px| {
        for (k, v) in px.iter_mut().enumerate() {
            if Some(k) != alpha {
                *v *= scale;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;

    #[test]
    fn a_constant_map_gives_pi_times_its_luminance() {
        for (w, h) in [(2, 1), (4, 2), (6, 3), (7, 5), (64, 32), (100, 51), (4096, 2048)] {
            let img = Image::from_fn_rgb(w, h, |_, _| [2.0, 2.0, 2.0]);
            let e = upward_illuminance(&img);
            let want = PI * 2.0 * (0.2126 + 0.7152 + 0.0722);
            assert!(((e - want) / want).abs() < 1e-12, "{w}x{h}: {e} vs {want}");
        }
    }

    #[test]
    fn a_sun_cap_and_a_cosine_sky_match_their_integrals() {
        // A cap of luminance 1 over the top k rows: E = pi sin^2(pi k / H), exactly.
        let (w, h) = (256, 128);
        let k = 10;
        let cap = Image::from_vec(w, h, 1, (0..w * h).map(|i| if i / w < k { 1.0 } else { 0.0 }).collect());
        let want = PI * (PI * k as f64 / h as f64).sin().powi(2);
        assert!((upward_illuminance(&cap) / want - 1.0).abs() < 1e-12);
        // L = 1 + cos(theta) above, 1e6 below (ignored): E = pi + 2 pi / 3, up to the texels'
        // piecewise-constant steps (O(1/H^2) relative: 1e-6 at H = 1024).
        let (w, h) = (2048, 1024);
        let sky = Image::from_vec(
            w,
            h,
            1,
            (0..w * h)
                .map(|i| {
                    let t = latlong::theta_of_row(i / w, h);
                    if t < FRAC_PI_2 {
                        1.0 + t.cos() as f32
                    } else {
                        1e6
                    }
                })
                .collect(),
        );
        let want = PI + 2.0 * PI / 3.0;
        let got = upward_illuminance(&sky);
        assert!((got / want - 1.0).abs() < 1e-6, "{got} vs {want}");
    }

    #[test]
    fn scaling_leaves_alpha() {
        let names = ["R", "G", "B", "A"].map(String::from).to_vec();
        let mut img = Image::with_names(1, 1, names, vec![1.0, 2.0, 3.0, 0.5]);
        scale_colour(&mut img, 2.0);
        assert_eq!(img.data, vec![2.0, 4.0, 6.0, 0.5]);
    }
}
