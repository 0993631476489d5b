//! The rough spheres shaded at every fourth or every second pixel in each direction, the others
//! interpolated.
//!
//! The rough lobes' radiance varies over the image on the scale of the lobes: at the protocol's
//! 960 x 540 a pixel turns the lobe's peak by about 0.8 degrees at the sphere's centre, where the
//! matte silver's lobe is about 12 degrees wide. So the pixels on a grid of stride 4 (the coarse
//! anchors) and of stride 2 (the fine anchors) are shaded ([`super::tiles`]) and the others are
//! Catmull-Rom interpolated from a 4 x 4 stencil of anchors (separable; at stride `s` a pixel at
//! offset `o` from its anchor line has the cubic convolution weights of `o / s`: `(0, 1, 0, 0)`,
//! `(-9, 111, 29, -3) / 128`, `(-1, 9, 9, -1) / 16`, `(-3, 29, 111, -9) / 128`), clamped to the
//! range of the anchors that weigh, so that no ring overshoots a highlight.
//!
//! A fully covered pixel is interpolated at a stride when every anchor of its stencil there is
//! fully covered and the peaks of neighbouring anchors in it are at most [`MAX_STEP`] lobe widths
//! apart; where the peak turns faster (towards the silhouette, and at smaller frames) it tries the
//! fine stride, and else it is shaded itself, as is every partly covered pixel. The coarse pass
//! runs first (its anchors are all shaded), then the fine one (whose anchors are shaded or filled
//! by the coarse pass). The error this adds is measured against a four times finer cut of the
//! texel tree: on the protocol's frame it is small beside the cut's own (tested; the book page
//! gives the measurements on the CC0 maps).

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use super::lobe_kernel::PixelLobe;
use super::principled::Principled;
use super::shading::lobe_width;
use super::Stage;

/// The largest angle between neighbouring anchors' peaks, in lobe widths, for a pixel between
/// them to be interpolated at stride 2.
pub const MAX_STEP: f64 = 0.5;
/// [`MAX_STEP`] at stride 4: smaller, since the interpolation's error grows with the step and the
/// coarse pass covers most of the sphere.
pub const MAX_COARSE_STEP: f64 = 0.4;

/// How a pixel of a rough sphere gets its radiance.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Fill {
    /// not a [`Stage::Shade`] pixel: nothing to shade
    Skip,
    /// its lobes summed over the map ([`super::tiles`])
    Shade,
    /// interpolated from the anchors of stride 4
    Coarse,
    /// interpolated from the anchors of stride 2 (shaded or coarse)
    Fine,
}

/// The passes: their stride, the pixels each fills and their largest step.
const PASSES: [(usize, Fill, f64); 2] = [(4, Fill::Coarse, MAX_COARSE_STEP), (2, Fill::Fine, MAX_STEP)];

/// How each pixel (row-major, `width` wide) gets its radiance. It depends on the frame and the
/// material alone, so the frame's plan keeps it ([`super::plan`]).
pub(super) fn fills(stages: &[Stage], width: usize, bsdf: &Principled) -> Vec<Fill> {
    let height = stages.len() / width.max(1);
    let full = |x: usize, y: usize| matches!(stages[y * width + x], Stage::Shade(_, _, a) if a == 1.0);
    // The fine anchors' peaks, on the grid of even columns and rows; None where not fully covered.
    // The coarse anchors are every second of them.
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
    // For each pass, whether the pixels of each cell of its anchor grid (the cell whose top-left
    // anchor is (ax, ay)) can be interpolated from the 4 x 4 anchors around it: all fully covered,
    // neighbouring anchors' peaks at most the pass's step apart. The same for every pixel of the
    // cell, so it is decided once a cell.
    let cells: Vec<Vec<bool>> = PASSES
        .iter()
        .map(|&(stride, _, step)| {
            let min_cos = (step * lobe_width(bsdf)).min(std::f64::consts::PI).cos();
            let (k, sw, sh) = (stride / 2, width.div_ceil(stride), height.div_ceil(stride));
            let peak = |i: usize, j: usize| peaks[j * k * aw + i * k];
            let interpolable = |ax: usize, ay: usize| {
                if ax == 0 || ay == 0 || ax + 2 >= sw || ay + 2 >= sh {
                    return false;
                }
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
            (0..sw * sh).into_par_iter().map(|c| interpolable(c % sw, c / sw)).collect()
        })
        .collect();
    (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            if !matches!(stages[i], Stage::Shade(..)) {
                return Fill::Skip;
            }
            if !full(x, y) {
                return Fill::Shade;
            }
            for (&(stride, fill, _), cells) in PASSES.iter().zip(&cells) {
                if x % stride == 0 && y % stride == 0 {
                    return Fill::Shade;
                }
                if cells[(y / stride) * width.div_ceil(stride) + x / stride] {
                    return fill;
                }
            }
            Fill::Shade
        })
        .collect()
}

/// Cubic convolution (Catmull-Rom) weights at stride `stride` for a pixel `offset` past its
/// anchor line: those of `t = offset / stride`, exact in binary for strides 2 and 4.
fn weights(offset: usize, stride: usize) -> [f64; 4] {
    let t = offset as f64 / stride as f64;
    let (t2, t3) = (t * t, t * t * t);
    [(-t3 + 2.0 * t2 - t) / 2.0, (3.0 * t3 - 5.0 * t2 + 2.0) / 2.0, (-3.0 * t3 + 4.0 * t2 + t) / 2.0, (t3 - t2) / 2.0]
}

/// Fills the pixels of `rgb` (row-major, `width` wide) that [`fills`] marks as interpolated, the
/// coarse pass first; `spans` holds each row's pixels that are not empty
/// ([`super::plan::Plan::spans`]), the only ones looked at.
pub(super) fn fill(spans: &[Range<usize>], fills: &[Fill], rgb: &mut [[f64; 3]], width: usize) {
    for (stride, which, _) in PASSES {
        fill_pass(spans, fills, rgb, width, stride, which);
    }
}

/// One pass of [`fill`]: the pixels marked `which`, from the anchors of `stride`.
fn fill_pass(spans: &[Range<usize>], fills: &[Fill], rgb: &mut [[f64; 3]], width: usize, stride: usize, which: Fill) {
    // The anchors are read while the rows are written: a copy of them.
    let (aw, height) = (width.div_ceil(stride), rgb.len() / width.max(1));
    let anchors: Vec<[f64; 3]> = (0..height.div_ceil(stride))
        .flat_map(|j| (0..aw).map(move |i| (i, j)))
        .map(|(i, j)| rgb[stride * j * width + stride * i])
        .collect();
    let table: Vec<[f64; 4]> = (0..stride).map(|offset| weights(offset, stride)).collect();
    rgb.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, row)| {
        for x in spans[y].clone() {
            if fills[y * width + x] != which {
                continue;
            }
            let (ax, ay) = (x / stride, y / stride);
            let (wx, wy) = (table[x % stride], table[y % stride]);
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
            row[x] = [0, 1, 2].map(|c| sum[c].max(lo[c]).min(hi[c]));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::weights;

    #[test]
    fn the_weights_are_catmull_roms_and_exact_in_binary() {
        assert_eq!(weights(0, 2), [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(weights(0, 4), [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(weights(1, 2), [-1.0 / 16.0, 9.0 / 16.0, 9.0 / 16.0, -1.0 / 16.0]);
        assert_eq!(weights(2, 4), weights(1, 2));
        assert_eq!(weights(1, 4), [-9.0 / 128.0, 111.0 / 128.0, 29.0 / 128.0, -3.0 / 128.0]);
        assert_eq!(weights(3, 4), [-3.0 / 128.0, 29.0 / 128.0, 111.0 / 128.0, -9.0 / 128.0]);
        for (o, s) in [(1, 4), (2, 4), (3, 4), (1, 2)] {
            assert_eq!(weights(o, s).iter().sum::<f64>(), 1.0);
        }
    }
}
