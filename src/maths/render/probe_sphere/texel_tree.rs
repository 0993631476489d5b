//! The rough lobes integrated over the environment's texels, with blocks of texels taken as one
//! where the lobe hardly varies across them: a deterministic sum that tends to the exact integral
//! of the map as the refinement ratio goes to 0 (no sampling pattern, no noise).
//!
//! The integral is `Lo = int L(l) g(l) dl`, `g = (f_spec + diffuse f_d) cos` of
//! [`super::principled`] where light reaches the point (`Ng . l > 0`), 0 elsewhere; `g` is the same
//! for the three colour channels (the protocol's materials are grey).
//!
//! **The tree.** Level 0 holds the map's texels `i`, each with its power `P_i = L_i dOmega_i` (RGB;
//! `dOmega_i = (2 pi / W)(cos theta_top - cos theta_bottom)`, the texel's exact solid angle) and its
//! centre direction; level `k + 1` groups 2 x 2 nodes of level `k` (the last of an odd side takes
//! what remains), with the summed power, the mean direction of its children weighted by their
//! luminance power (by their size where the block is black) and a bounding cone (`max over children
//! of angle(c, c_child) + r_child`, from the texel's own corners at level 0).
//!
//! **The sum.** From the level of at most 16 x 8 nodes down: a node wholly below the horizon of
//! the corrected normal or of the triangle is skipped; a node is taken whole, adding `g(c) P`, when
//! its cone's radius `r` is at most `cut * min(delta + w, 1)`, with `delta` the angle from the cone to
//! the specular lobe's peak (the mirror direction of `v`), `w = 2 alpha` the lobe's width and the 1
//! radian that bounds the diffuse lobe's scale; otherwise its children are visited. A texel that is
//! still too large (a map coarse against the lobe) is split into `s x s` cells of its `(u, theta)`
//! box, each of its exact solid angle and the texel's radiance, `s` the smallest that meets the same
//! test (at most 32).
//!
//! What this converges to is the integral of the map as piecewise constant over its texels; Cycles
//! reads the map bilinearly, whose integral against a lobe `w` wide differs by about
//! `(h / w)^2 / 24` relative for texels `h` wide (a tent against a box of the same area): 0.2% for a
//! 256-wide map and the matte silver lobe. A node's error is second order in its radius against the
//! lobe's scale (the mean direction removes the first-order term), so the sum converges like
//! `cut^2` or a little slower (measured), always from below on the GGX lobe's convex tail. The
//! operator's tests state the default's error against the lobe's albedo and against `cut / 4`.

use std::f64::consts::PI;
use std::sync::{Arc, Mutex};

use glam::DVec3;

use super::recent::{recent_slot, Recent};

use crate::values::Image;

/// The coarsest level visited has at most this many nodes across.
const TOP_WIDTH: usize = 16;
/// The finest split of one texel, per side.
pub(super) const MAX_SPLIT: usize = 32;

pub(super) struct Level {
    pub(super) width: usize,
    pub(super) height: usize,
    /// row-major
    pub(super) nodes: Vec<Node>,
}

/// A node as the sums read it, its fields side by side: a visit loads one or two cache lines
/// instead of one from each of eight arrays (which is where the tile walk's time went).
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) centre: DVec3,
    pub(super) power: [f64; 3],
    pub(super) radius: f64,
    /// `sin(min(radius, pi / 2))`: the cone is below a horizon when its axis is that far below
    pub(super) sin_radius: f64,
    /// `cos(min(radius, pi / 2))`, for the horizons of a tile ([`super::tile_cut`])
    pub(super) cos_radius: f64,
    /// the node is taken whole when `centre . peak <= accept_cos` (the refinement test, see
    /// [`TexelTree::new`]); 2 for always, -2 for never
    pub(super) accept_cos: f64,
    /// the sine of the angle whose cosine `accept_cos` is (0 for always and never)
    pub(super) accept_sin: f64,
    /// that angle, `acos(accept_cos)` (NaN for always and never)
    pub(super) accept_angle: f64,
}

impl Node {
    /// The node of axis `centre`, `power` and bounding radius `radius`, with the tests of a tree
    /// refined with ratio `cut` around a lobe `w` wide ([`TexelTree::new`]).
    fn new(centre: DVec3, power: [f64; 3], radius: f64, cut: f64, w: f64) -> Node {
        let accept_cos = if radius <= cut * w.min(1.0) {
            2.0
        } else if radius > cut {
            -2.0
        } else {
            let delta = radius + radius / cut - w;
            if delta >= PI {
                -2.0
            } else {
                delta.cos()
            }
        };
        Node {
            centre,
            power,
            radius,
            sin_radius: radius.min(0.5 * PI).sin(),
            cos_radius: radius.min(0.5 * PI).cos(),
            accept_cos,
            accept_sin: if accept_cos.abs() <= 1.0 { (1.0 - accept_cos * accept_cos).sqrt() } else { 0.0 },
            accept_angle: accept_cos.acos(),
        }
    }
}

/// The map's texels as a tree of blocks.
pub struct TexelTree {
    pub(super) levels: Vec<Level>,
    /// level 0's texel size
    pub(super) width: usize,
    pub(super) height: usize,
    /// the refinement ratio and lobe width the tree was made for
    pub(super) cut: f64,
    pub(super) w: f64,
}

/// Maps of at most this many texels have their tree's level 0 kept (96 MB of nodes at most).
const KEPT_TEXELS: usize = 1 << 20;

/// Level 0 of a tree of a `width` x `height` map with parameters `cut` and `w`, without the
/// texels' power: the centres, radii and tests, which depend on those alone. The last four of at
/// most [`KEPT_TEXELS`] are kept, since an evaluation makes trees of one size (the protocol's
/// 256 x 128) and two materials for every map.
fn texels(width: usize, height: usize, cut: f64, w: f64) -> Arc<Vec<Node>> {
    static KEPT: Recent<(usize, usize, u64, u64), Arc<Vec<Node>>> = Mutex::new(Vec::new());
    let make = || {
        let mut nodes = Vec::with_capacity(width * height);
        for y in 0..height {
            let (t0, t1) = (PI * y as f64 / height as f64, PI * (y + 1) as f64 / height as f64);
            for x in 0..width {
                let (u0, u1) = (x as f64 / width as f64, (x + 1) as f64 / width as f64);
                let c = direction(0.5 * (u0 + u1), 0.5 * (t0 + t1));
                let r = [(u0, t0), (u1, t0), (u0, t1), (u1, t1)]
                    .iter()
                    .map(|&(u, t)| c.angle_between(direction(u, t)))
                    .fold(0.0, f64::max);
                nodes.push(Node::new(c, [0.0; 3], r, cut, w));
            }
        }
        Arc::new(nodes)
    };
    if width.saturating_mul(height) > KEPT_TEXELS {
        return make();
    }
    recent_slot(&KEPT, (width, height, cut.to_bits(), w.to_bits()), 4).get_or_init(make).clone()
}

/// The Blender direction at texture coordinate `u` and polar angle `theta` (from +Z): the inverse
/// of Cycles' `u = 0.5 - atan2(y, x) / (2 pi)`.
pub(super) fn direction(u: f64, theta: f64) -> DVec3 {
    let phi = PI * (1.0 - 2.0 * u);
    let (st, ct) = theta.sin_cos();
    DVec3::new(st * phi.cos(), st * phi.sin(), ct)
}

/// The exact solid angle of the box `[u0, u1] x [theta0, theta1]`.
pub(super) fn box_solid_angle(du: f64, theta0: f64, theta1: f64) -> f64 {
    2.0 * PI * du * (theta0.cos() - theta1.cos())
}

impl TexelTree {
    /// The tree of `map`, refined with ratio `cut` around a lobe `w` radians wide: a node of radius
    /// `r` is taken whole when `r <= cut * min(max(delta - r, 0) + w, 1)`, `delta` its axis's angle
    /// from the lobe's peak. The test is stored per node as a cosine, so that the sum compares one
    /// dot product: always when `r <= cut * min(w, 1)`, never when `r > cut`, else when `delta >=
    /// r + r / cut - w`.
    pub fn new(map: &Image, cut: f64, w: f64) -> TexelTree {
        let (width, height) = (map.width, map.height);
        let mut nodes = Vec::clone(&texels(width, height, cut, w));
        for (y, row) in nodes.chunks_mut(width.max(1)).enumerate() {
            let (t0, t1) = (PI * y as f64 / height as f64, PI * (y + 1) as f64 / height as f64);
            let omega = box_solid_angle(1.0 / width as f64, t0, t1);
            for (x, node) in row.iter_mut().enumerate() {
                node.power = map.rgb(x, y).map(|v| v as f64 * omega);
            }
        }
        let mut levels = vec![Level { width, height, nodes }];
        while let Some(l) = levels.last().filter(|l| l.width > TOP_WIDTH || l.height > TOP_WIDTH / 2) {
            let next = group(l, cut, w);
            levels.push(next);
        }
        TexelTree { levels, width, height, cut, w }
    }

    /// `sum g(l) P` over the map, refining around the lobe of peak `peak`; a cone of axis `c` and
    /// radius `r` is wholly below the horizon of each of `horizons` when `c . n < -sin(r)`, and
    /// `g(l)` is the lobe.
    pub fn sum(&self, peak: DVec3, horizons: [DVec3; 2], g: impl Fn(DVec3) -> f64) -> [f64; 3] {
        let (cut, w) = (self.cut, self.w);
        let allowed = |c: DVec3, r: f64| r <= cut * ((c.angle_between(peak) - r).max(0.0) + w).min(1.0);
        let mut acc = [0.0; 3];
        self.walk(|node, k, x, y| {
            let (c, p) = (node.centre, node.power);
            if p == [0.0; 3] || horizons.iter().any(|n| c.dot(*n) < -node.sin_radius) {
                return false;
            }
            if c.dot(peak) <= node.accept_cos {
                let v = g(c);
                (0..3).for_each(|ch| acc[ch] += v * p[ch]);
                false
            } else if k > 0 {
                true
            } else {
                // A texel larger than the lobe allows: split it into cells of its radiance.
                let r = node.radius;
                let s = (2..=MAX_SPLIT).find(|&s| allowed(c, r / s as f64)).unwrap_or(MAX_SPLIT);
                let mut weight = 0.0;
                self.texel_cells(x, y, s, |d, omega| weight += g(d) * omega);
                let texel_omega = self.texel_omega(y);
                (0..3).for_each(|ch| acc[ch] += weight / texel_omega * p[ch]);
                false
            }
        });
        acc
    }

    /// Walks the tree from its top level down: `visit(node, k, x, y)` handles the node at `(x, y)`
    /// of level `k` and says whether to visit its children (ignored at level 0, whose
    /// texels the visitor splits itself). Children are visited depth first, in a fixed order, so a
    /// sum over the walk is deterministic.
    pub(super) fn walk(&self, mut visit: impl FnMut(&Node, usize, usize, usize) -> bool) {
        let top = self.levels.len() - 1;
        let mut stack: Vec<(usize, usize, usize)> = Vec::with_capacity(64);
        let t = &self.levels[top];
        for y in 0..t.height {
            for x in 0..t.width {
                stack.push((top, x, y));
            }
        }
        while let Some((k, x, y)) = stack.pop() {
            let l = &self.levels[k];
            if visit(&l.nodes[y * l.width + x], k, x, y) && k > 0 {
                let f = &self.levels[k - 1];
                for cy in 2 * y..(2 * y + 2).min(f.height) {
                    for cx in 2 * x..(2 * x + 2).min(f.width) {
                        stack.push((k - 1, cx, cy));
                    }
                }
            }
        }
    }

    /// The exact solid angle of a texel of row `y`.
    pub(super) fn texel_omega(&self, y: usize) -> f64 {
        let h0 = self.height as f64;
        box_solid_angle(1.0 / self.width as f64, PI * y as f64 / h0, PI * (y + 1) as f64 / h0)
    }

    /// The `s x s` cells of texel `(x, y)`'s `(u, theta)` box: `cell(direction of its centre, its
    /// exact solid angle)` for each, row by row.
    pub(super) fn texel_cells(&self, x: usize, y: usize, s: usize, mut cell: impl FnMut(DVec3, f64)) {
        let (w0, h0) = (self.width as f64, self.height as f64);
        let du = 1.0 / (w0 * s as f64);
        for sy in 0..s {
            let t0 = PI * (y as f64 + sy as f64 / s as f64) / h0;
            let t1 = PI * (y as f64 + (sy + 1) as f64 / s as f64) / h0;
            let omega = box_solid_angle(du, t0, t1);
            for sx in 0..s {
                let u = (x as f64 + (sx as f64 + 0.5) / s as f64) / w0;
                cell(direction(u, 0.5 * (t0 + t1)), omega);
            }
        }
    }
}

/// The next level: 2 x 2 blocks of `l` with their power, mean direction and bounding cone, and
/// the tests of a tree of ratio `cut` and lobe width `w`.
fn group(l: &Level, cut: f64, w: f64) -> Level {
    let (width, height) = (l.width.div_ceil(2), l.height.div_ceil(2));
    let mut nodes = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let children = || {
                (2 * y..(2 * y + 2).min(l.height))
                    .flat_map(move |cy| (2 * x..(2 * x + 2).min(l.width)).map(move |cx| &l.nodes[cy * l.width + cx]))
            };
            let mut power = [0.0; 3];
            let (mut lum, mut geo) = (DVec3::ZERO, DVec3::ZERO);
            for child in children() {
                let p = child.power;
                (0..3).for_each(|ch| power[ch] += p[ch]);
                // Weights: the child's luminance power, and its share of the sphere (its radius
                // squared stands for its solid angle, to first order).
                let y_power = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
                lum += y_power.max(0.0) * child.centre;
                geo += child.radius * child.radius * child.centre;
            }
            let first = l.nodes[2 * y * l.width + 2 * x].centre;
            let c = if lum.length() > 1e-300 { lum.normalize() } else { geo.normalize_or(first) };
            let r = children().map(|child| c.angle_between(child.centre) + child.radius).fold(0.0, f64::max);
            nodes.push(Node::new(c, power, r.min(PI), cut, w));
        }
    }
    Level { width, height, nodes }
}
