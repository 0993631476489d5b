//! The rough spheres shaded at every second pixel in each direction, the others interpolated.
//!
//! The rough lobes' radiance varies over the image on the scale of the lobes: at the protocol's
//! 960 x 540 a pixel turns the lobe's peak by about 0.8 degrees at the sphere's centre, where the
//! matte silver's lobe is about 12 degrees wide. So the pixels with even column and row (the
//! anchors) are shaded ([`super::tiles`]) and every other fully covered pixel whose 4 x 4 stencil
//! of anchors is fully covered is Catmull-Rom interpolated from them (separable; at stride 2 a pixel
//! sits on an anchor line or halfway, weights `(0, 1, 0, 0)` or `(-1, 9, 9, -1) / 16`), clamped to
//! its stencil's range so that no ring overshoots a highlight.
//!
//! Where the peak turns faster (towards the silhouette, and at smaller frames) the interpolation
//! would blur the lobes' detail, so a pixel is interpolated only when the peaks of neighbouring
//! anchors in its stencil are at most [`MAX_STEP`] lobe widths apart; every other pixel, and every
//! partly covered one, is shaded itself. The error this adds is measured against a four times
//! finer cut of the texel tree: on the protocol's frame it is small beside the cut's own (tested
//! on a smaller frame; the book page gives the measurements on the CC0 maps).

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use super::lobe_kernel::PixelLobe;
use super::principled::Principled;
use super::shading::lobe_width;
use super::Stage;

/// The largest angle between neighbouring anchors' peaks, in lobe widths, for a pixel between
/// them to be interpolated.
pub const MAX_STEP: f64 = 0.5;

/// Whether each pixel (row-major, `width` wide) is to be shaded itself: the anchors and every
/// shaded pixel that cannot be interpolated; `false` for the pixels interpolated and for those
/// not shaded at all. It depends on the frame and the material alone, so the frame's plan keeps
/// it ([`super::plan`]).
pub(super) fn shaded_pixels(stages: &[Stage], width: usize, bsdf: &Principled) -> Vec<bool> {
    let height = stages.len() / width.max(1);
    let full = |x: usize, y: usize| matches!(stages[y * width + x], Stage::Shade(_, _, a) if a == 1.0);
    // The anchors' peaks, on the grid of even columns and rows; None where not fully covered.
    let (aw, ah) = (width.div_ceil(2), height.div_ceil(2));
    let peaks: Vec<Option<DVec3>> = (0..aw * ah)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (2 * (i % aw), 2 * (i / aw));
            match stages[y * width + x] {
                Stage::Shade(hit, v, 1.0) => PixelLobe::new(bsdf, &hit, v).map(|k| k.peak),
                _ => None,
            }
        })
        .collect();
    let min_cos = (MAX_STEP * lobe_width(bsdf)).min(std::f64::consts::PI).cos();
    let interpolable = |x: usize, y: usize| {
        let (ax, ay) = (x / 2, y / 2);
        if ax == 0 || ay == 0 || ax + 2 >= aw || ay + 2 >= ah {
            return false;
        }
        let peak = |i: usize, j: usize| peaks[j * aw + i];
        for j in ay - 1..=ay + 2 {
            for i in ax - 1..=ax + 2 {
                let Some(p) = peak(i, j) else { return false };
                let near = |q: Option<DVec3>| q.is_some_and(|q| p.dot(q) >= min_cos);
                if (i > ax - 1 && !near(peak(i - 1, j))) || (j > ay - 1 && !near(peak(i, j - 1))) {
                    return false;
                }
            }
        }
        true
    };
    (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            match stages[i] {
                Stage::Shade(..) => (x % 2 == 0 && y % 2 == 0) || !full(x, y) || !interpolable(x, y),
                _ => false,
            }
        })
        .collect()
}

/// Catmull-Rom weights at stride 2: on an anchor line, or halfway between two anchors.
fn weights(offset: usize) -> [f64; 4] {
    if offset == 0 {
        [0.0, 1.0, 0.0, 0.0]
    } else {
        [-1.0 / 16.0, 9.0 / 16.0, 9.0 / 16.0, -1.0 / 16.0]
    }
}

/// Fills the pixels of `rgb` (row-major, `width` wide) that [`shaded_pixels`] left to be
/// interpolated, from the shaded anchors around them; `spans` holds each row's pixels that are
/// not empty ([`super::plan::Plan::spans`]), the only ones looked at.
pub(super) fn fill(stages: &[Stage], spans: &[Range<usize>], shaded: &[bool], rgb: &mut [[f64; 3]], width: usize) {
    // The anchors are read while the rows are written: a copy of them (a quarter of the image).
    let (aw, height) = (width.div_ceil(2), rgb.len() / width.max(1));
    let anchors: Vec<[f64; 3]> = (0..height.div_ceil(2))
        .flat_map(|j| (0..aw).map(move |i| (i, j)))
        .map(|(i, j)| rgb[2 * j * width + 2 * i])
        .collect();
    rgb.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, row)| {
        for x in spans[y].clone() {
            let (i, out) = (y * width + x, &mut row[x]);
            if shaded[i] || !matches!(stages[i], Stage::Shade(..)) {
                continue;
            }
            let (ax, ay) = (x / 2, y / 2);
            let (wx, wy) = (weights(x % 2), weights(y % 2));
            let mut sum = [0.0; 3];
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for (j, &wy) in wy.iter().enumerate() {
                for (k, &wx) in wx.iter().enumerate() {
                    let a = anchors[(ay + j - 1) * aw + ax + k - 1];
                    let w = wy * wx;
                    for c in 0..3 {
                        sum[c] += w * a[c];
                        // The range of the anchors that weigh: along an anchor line, that line's.
                        if w != 0.0 {
                            lo[c] = lo[c].min(a[c]);
                            hi[c] = hi[c].max(a[c]);
                        }
                    }
                }
            }
            *out = [0, 1, 2].map(|c| sum[c].max(lo[c]).min(hi[c]));
        }
    });
}
