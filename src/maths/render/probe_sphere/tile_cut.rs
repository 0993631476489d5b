//! One cut of the texel tree for a tile of pixels: the nodes [`TexelTree::sum`] would take for any
//! pixel of the tile, flattened into a [`FlatCut`] that every pixel of the tile then sums its own
//! lobes over ([`super::lobe_kernel`]). Neighbouring pixels have nearly the same normal and view,
//! so their cuts nearly agree; the tree walk is paid once per tile instead of once per pixel.
//!
//! **The tests, made conservative.** The tile's pixels' lobe peaks lie in a cone of axis `a` and
//! half-angle `beta` (the largest angle from their normalised mean), and their two horizons' normals
//! (corrected and triangle) in cones of half-angles `gamma_n`, `gamma_g`. For a node of axis `c`
//! and radius `r`, every pixel's peak is at least `angle(c, a) - beta` from `c`, and every pixel's
//! horizon normal within `gamma` of its cone's axis, so:
//!
//! - the node is skipped only when it lies below a horizon for every pixel: `angle(c, b) > pi/2 + r
//!   + gamma`, `c . b < -sin(r + gamma)` (never when `r + gamma >= pi/2`);
//! - it is taken whole only when every pixel would take it: `angle(c, a) >= delta + beta`, `delta`
//!   the node's acceptance angle (`accept_cos = cos delta`), i.e. `c . a <= cos(delta + beta)`
//!   (never when `delta + beta >= pi`; always when the node is always taken);
//! - a texel is split into `s x s` cells with the smallest `s` that meets the refinement test at the
//!   smallest angle any pixel's peak can have, `max(angle(c, a) - beta, 0)`.
//!
//! So the tile's cut is at least as fine as each pixel's own, node by node: a pixel's sum over it
//! differs from its own [`TexelTree::sum`] only where the tile refined further, by less than the
//! pixel's own cut error (tested against a four times finer cut). Nodes below a pixel's horizon
//! that the tile keeps add 0 to that pixel (its lobes vanish there). A tile of one pixel has
//! `beta = gamma = 0` and gives that pixel's own cut exactly (tested).

use std::f64::consts::PI;

use glam::DVec3;

use super::lobe_kernel::{FlatCut, PixelLobe};
use super::texel_tree::{TexelTree, MAX_SPLIT};

/// A unit axis and the cosine and sine of a half-angle about it.
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: DVec3,
    angle: f64,
    cos: f64,
    sin: f64,
}

impl Cone {
    /// The cone about the normalised mean of `dirs` (unit) that holds them all, with 1e-9 rad of
    /// margin for rounding; `None` when the mean vanishes. One direction is its own axis, as it is.
    fn around(dirs: impl Iterator<Item = DVec3> + Clone) -> Option<Cone> {
        let mut it = dirs.clone();
        let first = it.next()?;
        if it.next().is_none() {
            return Some(Cone { axis: first, angle: 0.0, cos: 1.0, sin: 0.0 });
        }
        let axis = dirs.clone().fold(DVec3::ZERO, |a, d| a + d).try_normalize()?;
        // atan2 of the cross and dot products: exact to rounding at small angles, where acos of a
        // dot product near 1 is not; the margin covers that rounding and the mean's.
        let angle = dirs.map(|d| axis.cross(d).length().atan2(axis.dot(d))).fold(0.0, f64::max);
        let angle = (angle + 1e-9).min(PI);
        let (sin, cos) = angle.sin_cos();
        Some(Cone { axis, angle, cos, sin })
    }
}

/// The cones of a tile's lobes.
#[derive(Clone, Copy, Debug)]
pub struct TileCones {
    peak: Cone,
    horizons: [Cone; 2],
}

impl TileCones {
    /// The cones of `lobes` (at least one); `None` when a mean vanishes (lobes spread over the
    /// whole sphere, which a tile of neighbouring pixels never is: the caller splits the tile).
    pub fn new(lobes: &[PixelLobe]) -> Option<TileCones> {
        Some(TileCones {
            peak: Cone::around(lobes.iter().map(|k| k.peak))?,
            horizons: [Cone::around(lobes.iter().map(|k| k.n))?, Cone::around(lobes.iter().map(|k| k.ng))?],
        })
    }

    /// The spread of the lobes' peaks, radians.
    pub fn peak_spread(&self) -> f64 {
        self.peak.angle
    }
}

impl TexelTree {
    /// The tile's cut (see the module documentation) into `out`, cleared first and padded.
    pub fn tile_cut(&self, cones: &TileCones, out: &mut FlatCut) {
        out.clear();
        let (a, beta) = (cones.peak.axis, cones.peak.angle);
        self.walk(|node, k, x, y| {
            let (c, p) = (node.centre, node.power);
            if p == [0.0; 3] {
                return false;
            }
            let (sr, cr) = (node.sin_radius, node.cos_radius);
            let below = |h: &Cone| node.radius + h.angle < 0.5 * PI && c.dot(h.axis) < -(sr * h.cos + cr * h.sin);
            if cones.horizons.iter().any(below) {
                return false;
            }
            let accept = node.accept_cos;
            let whole = if accept > 1.0 {
                true
            } else if accept < -1.0 {
                false
            } else if beta == 0.0 {
                c.dot(a) <= accept
            } else {
                let delta = node.accept_angle;
                delta + beta < PI && c.dot(a) <= accept * cones.peak.cos - node.accept_sin * cones.peak.sin
            };
            if whole {
                out.push(c, p);
                false
            } else if k > 0 {
                true
            } else {
                self.split_texel(x, y, node.radius, p, (c.angle_between(a) - beta).max(0.0), out);
                false
            }
        });
        out.pad();
    }

    /// A texel larger than the lobes allow, split into `s x s` cells of its radiance, `s` the
    /// smallest that meets the refinement test at angle `delta` from the nearest peak.
    fn split_texel(&self, x: usize, y: usize, r: f64, p: [f64; 3], delta: f64, out: &mut FlatCut) {
        let (cut, w) = (self.cut, self.w);
        let allowed = |r: f64| r <= cut * ((delta - r).max(0.0) + w).min(1.0);
        let s = (2..=MAX_SPLIT).find(|&s| allowed(r / s as f64)).unwrap_or(MAX_SPLIT);
        let texel_omega = self.texel_omega(y);
        self.texel_cells(x, y, s, |d, omega| {
            let share = omega / texel_omega;
            out.push(d, p.map(|v| v * share));
        });
    }
}
