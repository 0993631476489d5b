//! The rough lobes of every pixel, by tiles: the pixels of a [`TILE`] x [`TILE`] tile share one cut
//! of the texel tree ([`super::tile_cut`], at least as fine as each pixel's own) and each sums its
//! own lobes over it ([`super::lobe_kernel`]). A tile whose lobe peaks spread more than
//! [`MAX_SPREAD`] (near the silhouette, where the normal turns fast) is split into quarters, down to
//! single pixels, so that its cut stays close to its pixels' own.
//!
//! The tiles, their pixels' lobes and cones depend on the frame and the material, not on the map:
//! the frame's plan keeps them ([`band_tiles`]), and a render cuts the tree and sums
//! ([`shade_tiles`]). Bands of tile rows run in parallel ([`super::render`]); a pixel's value
//! depends only on its tile's pixels, so the image is the same whatever the number of threads.

use super::interpolation::Fill;
use super::lobe_kernel::{self, FlatCut, PixelLobe};
use super::principled::Principled;
use super::texel_tree::TexelTree;
use super::tile_cut::TileCones;
use super::Stage;

/// The tile's side, pixels.
pub const TILE: usize = 8;
/// The largest spread (half-angle, radians) of a tile's lobe peaks before it is split: a wider
/// tile shares a finer cut (more nodes a pixel, fewer walks); the sphere evaluation's benchmark
/// page gives the times and errors of 0.2 and 0.4.
pub const MAX_SPREAD: f64 = 0.4;

/// A tile's pixels (their index in the band and coverage), their lobes and the cones that bound
/// them: all a tile needs before the map is read, so a frame's plan keeps its tiles for each rough
/// material ([`super::plan::Plan::tiles`]) and a render only cuts the tree and sums.
pub(super) struct Tile {
    cones: TileCones,
    lobes: Vec<PixelLobe>,
    at: Vec<usize>,
    coverage: Vec<f64>,
}

/// The tiles of a band of at most `tile` rows of `width` pixels (`stages`, with `shade` marking
/// the [`Stage::Shade`] pixels to shade), by tiles of `tile` x `tile`, split while their lobes'
/// peaks spread too far.
pub(super) fn band_tiles(bsdf: &Principled, band: Band, tile: usize) -> Vec<Tile> {
    let (width, stages, _) = band;
    let mut tiles = Vec::new();
    if width == 0 {
        return tiles;
    }
    let height = stages.len() / width;
    for x0 in (0..width).step_by(tile) {
        let rect = Rect { x0, x1: (x0 + tile).min(width), y0: 0, y1: height };
        split(bsdf, band, rect, &mut tiles);
    }
    tiles
}

/// The premultiplied radiance of every pixel of `tiles` (a band's, [`band_tiles`]) into `out` (the
/// band's pixels; the others are left as they are).
pub(super) fn shade_tiles(tree: &TexelTree, tiles: &[Tile], out: &mut [[f64; 3]]) {
    let mut cut = FlatCut::default();
    let level = crate::cpu::level();
    for t in tiles {
        tree.tile_cut(&t.cones, &mut cut);
        for ((k, &at), &a) in t.lobes.iter().zip(&t.at).zip(&t.coverage) {
            out[at] = lobe_kernel::sum(level, k, &cut).map(|v| v * a);
        }
    }
}

/// A band's width, stages and how each gets its radiance (those marked [`Fill::Shade`] are shaded).
pub(super) type Band<'a> = (usize, &'a [Stage], &'a [Fill]);

#[derive(Clone, Copy)]
struct Rect {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// The tile of the pixels of `rect` into `tiles`, or its quarters' while their peaks spread too
/// far.
fn split(bsdf: &Principled, band: Band, rect: Rect, tiles: &mut Vec<Tile>) {
    let (width, stages, shade) = band;
    let (mut lobes, mut at, mut coverage) = (Vec::new(), Vec::new(), Vec::new());
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            if shade[y * width + x] != Fill::Shade {
                continue;
            }
            if let Stage::Shade(hit, v, a) = stages[y * width + x] {
                if let Some(lobe) = PixelLobe::new(bsdf, &hit, v) {
                    lobes.push(lobe);
                    at.push(y * width + x);
                    coverage.push(a);
                }
            }
        }
    }
    if lobes.is_empty() {
        return;
    }
    let single = rect.x1 - rect.x0 == 1 && rect.y1 - rect.y0 == 1;
    let cones = TileCones::new(&lobes);
    let Some(cones) = cones.filter(|c| single || c.peak_spread() <= MAX_SPREAD) else {
        // Quarters (halves of a thin rectangle), each a tile of its own.
        let (xm, ym) = ((rect.x0 + rect.x1).div_ceil(2), (rect.y0 + rect.y1).div_ceil(2));
        for (x0, x1) in [(rect.x0, xm), (xm, rect.x1)] {
            for (y0, y1) in [(rect.y0, ym), (ym, rect.y1)] {
                if x0 < x1 && y0 < y1 {
                    split(bsdf, band, Rect { x0, x1, y0, y1 }, tiles);
                }
            }
        }
        return;
    };
    tiles.push(Tile { cones, lobes, at, coverage });
}
