//! Bilinear lookups in images, one rule for every layout: a continuous position `(fx, fy)` in
//! pixel units with pixel (x, y)'s centre at `(x, y)` (so `fx = u W - 0.5` for a texture
//! coordinate u in [0, 1]) reads its four surrounding pixels with weights
//! `(1 - tx)(1 - ty), tx (1 - ty), (1 - tx) ty, tx ty`, `tx = fx - floor(fx)`.
//!
//! Where a tap lies outside the image, the layout decides (`at`): a lat-long map wraps in
//! longitude and holds its first and last rows towards the poles ([`latlong`]); a photograph
//! holds its border pixels; a masked layout (the angular probe's disc, a fisheye's circle)
//! drops the tap and the weights kept are renormalised, so a lookup never mixes in what is not
//! there.

use glam::DVec3;

use crate::geometry::latlong;
use crate::values::Image;

/// Writes into `out` (one value per channel of `img`) the bilinear interpolation at `(fx, fy)`
/// over the taps that `at` maps to a pixel, renormalised by their weights; returns `false`
/// (and leaves `out` at 0) when no tap of positive weight remains.
pub fn lookup(
    img: &Image,
    fx: f64,
    fy: f64,
    at: impl Fn(isize, isize) -> Option<(usize, usize)>,
    out: &mut [f64],
) -> bool {
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (x0, y0) = (x0 as isize, y0 as isize);
    out.fill(0.0);
    let mut wsum = 0.0;
    for (dx, dy, w) in
        [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)]
    {
        if w <= 0.0 {
            continue;
        }
        if let Some((x, y)) = at(x0 + dx, y0 + dy) {
            for (o, &v) in out.iter_mut().zip(img.pixel(x, y)) {
                *o += w * v as f64;
            }
            wsum += w;
        }
    }
    if wsum > 0.0 {
        out.iter_mut().for_each(|o| *o /= wsum);
        true
    } else {
        false
    }
}

/// The bilinear lookup of lat-long map `img` in direction `d` (any length but 0): the texel
/// grid of `geometry::latlong` (centres at `phi = 2 pi (x + 0.5) / W`,
/// `theta = pi (y + 0.5) / H`), wrapping across the seam x = 0 / W and holding the first and
/// last rows within half a row of the poles.
pub fn latlong(img: &Image, d: DVec3, out: &mut [f64]) {
    let (w, h) = (img.width as isize, img.height as isize);
    let (theta, phi) = latlong::angles(d.into());
    let fx = phi / (2.0 * std::f64::consts::PI) * w as f64 - 0.5;
    let fy = theta / std::f64::consts::PI * h as f64 - 0.5;
    lookup(img, fx, fy, |x, y| Some((x.rem_euclid(w) as usize, y.clamp(0, h - 1) as usize)), out);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bilinear_function_is_reproduced_exactly() {
        // f(x, y) = 1 + 2x + 3y + xy is bilinear: the lookup reproduces it between centres.
        let (w, h) = (6, 5);
        let f = |x: f64, y: f64| 1.0 + 2.0 * x + 3.0 * y + x * y;
        let data = (0..w * h).map(|i| f((i % w) as f64, (i / w) as f64) as f32).collect();
        let img = Image::from_vec(w, h, 1, data);
        let (wi, hi) = (w as isize - 1, h as isize - 1);
        let clamped = |img: &Image, fx: f64, fy: f64, out: &mut [f64]| {
            lookup(img, fx, fy, |x, y| Some((x.clamp(0, wi) as usize, y.clamp(0, hi) as usize)), out)
        };
        let mut out = [0.0];
        for &(fx, fy) in &[(0.0, 0.0), (2.25, 3.5), (4.9, 0.1), (5.0, 4.0)] {
            clamped(&img, fx, fy, &mut out);
            assert!((out[0] - f(fx, fy)).abs() < 1e-5, "{fx} {fy}: {} vs {}", out[0], f(fx, fy));
        }
        // Beyond the border the border is held.
        clamped(&img, -3.0, 2.0, &mut out);
        assert!((out[0] - f(0.0, 2.0)).abs() < 1e-5);
    }

    #[test]
    fn dropped_taps_renormalise_and_none_left_is_zero() {
        let img = Image::from_vec(2, 1, 1, vec![1.0, 100.0]);
        let mut out = [0.0];
        assert!(lookup(&img, 0.5, 0.0, |x, y| (x == 0 && y == 0).then_some((0, 0)), &mut out));
        assert_eq!(out[0], 1.0);
        assert!(!lookup(&img, 0.5, 0.0, |_, _| None, &mut out));
        assert_eq!(out[0], 0.0);
    }

    #[test]
    fn the_latlong_lookup_wraps_the_seam_and_hits_texel_centres() {
        let (w, h) = (8, 4);
        let data = (0..w * h).map(|i| i as f32).collect();
        let img = Image::from_vec(w, h, 1, data);
        let mut out = [0.0];
        for y in 0..h {
            for x in 0..w {
                latlong(&img, DVec3::from(latlong::texel_direction(x, y, w, h)), &mut out);
                assert!((out[0] - (y * w + x) as f64).abs() < 1e-9, "({x}, {y}): {}", out[0]);
            }
        }
        // On the seam (phi = 0), halfway between the last and the first column of row 1.
        latlong(&img, DVec3::from(latlong::direction(std::f64::consts::PI * 1.5 / h as f64, 0.0)), &mut out);
        assert!((out[0] - 0.5 * (8.0 + 15.0)).abs() < 1e-9, "{}", out[0]);
    }
}
