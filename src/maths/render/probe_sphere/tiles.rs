//! The rough lobes of every pixel, by tiles: the pixels of a [`TILE`] x [`TILE`] tile share one cut
//! of the texel tree ([`super::tile_cut`], at least as fine as each pixel's own) and each sums its
//! own lobes over it ([`super::lobe_kernel`]). A tile whose lobe peaks spread more than
//! [`MAX_SPREAD`] (near the silhouette, where the normal turns fast) is split into quarters, down to
//! single pixels, so that its cut stays close to its pixels' own.
//!
//! Bands of tile rows run in parallel ([`super::render`]); a pixel's value depends only on its
//! tile's pixels, so the image is the same whatever the number of threads.

use super::lobe_kernel::{self, FlatCut, PixelLobe};
use super::principled::Principled;
use super::texel_tree::TexelTree;
use super::tile_cut::TileCones;
use super::Stage;

/// The tile's side, pixels.
pub const TILE: usize = 8;
/// The largest spread (half-angle, radians) of a tile's lobe peaks before it is split.
pub const MAX_SPREAD: f64 = 0.2;

/// Scratch reused across the tiles of a row.
struct Scratch {
    cut: FlatCut,
    lobes: Vec<PixelLobe>,
    at: Vec<usize>,
}

/// The premultiplied radiance of every [`Stage::Shade`] pixel of `stages` that `shade` marks, a
/// band of at most `tile` rows of `width` pixels, into `out` (the band's pixels; the others are
/// left as they are), by tiles of `tile` x `tile`.
pub(super) fn shade_band(tree: &TexelTree, bsdf: &Principled, band: Band, tile: usize, out: &mut [[f64; 3]]) {
    let (width, stages, _) = band;
    if width == 0 {
        return;
    }
    let mut scratch = Scratch { cut: FlatCut::default(), lobes: Vec::new(), at: Vec::new() };
    let height = stages.len() / width;
    for x0 in (0..width).step_by(tile) {
        let rect = Rect { x0, x1: (x0 + tile).min(width), y0: 0, y1: height };
        shade_rect(tree, bsdf, band, rect, out, &mut scratch);
    }
}

/// A band's width, stages and which of them to shade.
pub(super) type Band<'a> = (usize, &'a [Stage], &'a [bool]);

#[derive(Clone, Copy)]
struct Rect {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// The pixels of `rect` into `out`, split while their peaks spread too far.
fn shade_rect(
    tree: &TexelTree,
    bsdf: &Principled,
    band: Band,
    rect: Rect,
    out: &mut [[f64; 3]],
    scratch: &mut Scratch,
) {
    let (width, stages, shade) = band;
    scratch.lobes.clear();
    scratch.at.clear();
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            if !shade[y * width + x] {
                continue;
            }
            if let Stage::Shade(hit, v, _) = stages[y * width + x] {
                if let Some(lobe) = PixelLobe::new(bsdf, &hit, v) {
                    scratch.lobes.push(lobe);
                    scratch.at.push(y * width + x);
                }
            }
        }
    }
    if scratch.lobes.is_empty() {
        return;
    }
    let single = rect.x1 - rect.x0 == 1 && rect.y1 - rect.y0 == 1;
    let cones = TileCones::new(&scratch.lobes);
    let Some(cones) = cones.filter(|c| single || c.peak_spread() <= MAX_SPREAD) else {
        // Quarters (halves of a thin rectangle), each shaded on its own.
        let (xm, ym) = ((rect.x0 + rect.x1).div_ceil(2), (rect.y0 + rect.y1).div_ceil(2));
        for (x0, x1) in [(rect.x0, xm), (xm, rect.x1)] {
            for (y0, y1) in [(rect.y0, ym), (ym, rect.y1)] {
                if x0 < x1 && y0 < y1 {
                    shade_rect(tree, bsdf, band, Rect { x0, x1, y0, y1 }, out, scratch);
                }
            }
        }
        return;
    };
    tree.tile_cut(&cones, &mut scratch.cut);
    let level = crate::cpu::level();
    for (k, &at) in scratch.lobes.iter().zip(&scratch.at) {
        let rgb = lobe_kernel::sum(level, k, &scratch.cut);
        let a = stages[at].coverage();
        out[at] = rgb.map(|v| v * a);
    }
}
