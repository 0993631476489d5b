//! The rough lobes of one pixel summed over a flat list of directions and powers (a tile's cut of
//! the texel tree, [`super::tile_cut`]): `sum_i g(l_i) P_i`, `g` the lobes of [`super::shading::rough`]
//! (`f_spec cos + diffuse f_d cos` where `Ng . l > 0`, 0 elsewhere).
//!
//! The list is structure of arrays, padded to a multiple of [`LANES`] with zero-power entries at
//! the zero direction (masked: `Ng . 0 = 0`), so the body is one branch-free loop over the nodes
//! that the compiler vectorises (f64, four lanes with AVX2); every test of the scalar lobes
//! (`Principled::specular`, `disney_diffuse`, `bump_shadowing_term`) is a select here, whose
//! discarded lane may hold a NaN (`normalize` of `l = -v`) that never reaches the sum. The sum runs
//! in [`LANES`] partial sums per channel, added in a fixed order at the end, so the result is the
//! same bits at every level (`cpu::dispatch!`, no fused multiply-add; tested); against the scalar
//! lobes summed in the tree's order it differs by rounding only (relative 1e-12, tested).

use std::f64::consts::PI;

use glam::DVec3;

use super::principled::{Principled, Smith};
use super::shading::closure_normal;
use super::Hit;
use crate::cpu;

/// The nodes evaluated together; the list's length is a multiple of it.
pub const LANES: usize = 4;

/// A flat cut: node `i` is the direction `(x[i], y[i], z[i])` (unit, Blender's axes) carrying the
/// power `(r[i], g[i], b[i])`.
#[derive(Default)]
pub struct FlatCut {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub r: Vec<f64>,
    pub g: Vec<f64>,
    pub b: Vec<f64>,
}

impl FlatCut {
    pub fn clear(&mut self) {
        for v in [&mut self.x, &mut self.y, &mut self.z, &mut self.r, &mut self.g, &mut self.b] {
            v.clear();
        }
    }

    pub fn push(&mut self, d: DVec3, p: [f64; 3]) {
        self.x.push(d.x);
        self.y.push(d.y);
        self.z.push(d.z);
        self.r.push(p[0]);
        self.g.push(p[1]);
        self.b.push(p[2]);
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Pads to a multiple of [`LANES`] with nodes that add nothing.
    pub fn pad(&mut self) {
        while !self.len().is_multiple_of(LANES) {
            self.push(DVec3::ZERO, [0.0; 3]);
        }
    }
}

/// The constants of one pixel's lobes: its normals, view and the closures' parameters.
#[derive(Clone, Copy, Debug)]
pub struct PixelLobe {
    /// the corrected normal the closures use
    pub n: DVec3,
    /// the interpolated (shading) normal
    pub ni: DVec3,
    /// the triangle's normal
    pub ng: DVec3,
    /// towards the camera
    pub v: DVec3,
    /// the specular lobe's peak, the mirror direction of `v` about `n`
    pub peak: DVec3,
    cos_o: f64,
    a2: f64,
    /// separable Smith: `G1(cos_o)`; correlated: `sqrt(cos_o^2 (1 - a2) + a2)`
    g_o: f64,
    correlated: bool,
    /// Fresnel: 0 the constant `cspec0`, 1 the constant 1, 2 the remapped dielectric
    fresnel: u8,
    ior: f64,
    f0: f64,
    cspec0: f64,
    diffuse: f64,
    roughness: f64,
    /// the diffuse lobe's `(1 - cos_o)^5`
    fv: f64,
    /// whether `n` differs from `ni` (the diffuse lobe's bump shadowing applies)
    bump: bool,
    ni_dot_n: f64,
}

impl PixelLobe {
    /// The lobes of `bsdf` at `hit` seen along `v`; `None` when `n . v <= 0` (no light returns,
    /// as [`super::shading::rough`]).
    pub fn new(bsdf: &Principled, hit: &Hit, v: DVec3) -> Option<PixelLobe> {
        let n = closure_normal(hit, v);
        let cos_o = n.dot(v);
        if !(cos_o > 0.0) {
            return None;
        }
        let a2 = bsdf.alpha * bsdf.alpha;
        let correlated = bsdf.smith == Smith::Correlated;
        let g_o = if correlated {
            (cos_o * cos_o * (1.0 - a2) + a2).sqrt()
        } else {
            2.0 / (1.0 + (1.0 + a2 * (1.0 - cos_o * cos_o) / (cos_o * cos_o)).max(0.0).sqrt())
        };
        let fresnel = if bsdf.ior == 1.0 {
            0
        } else if bsdf.dielectric_f0() >= 1.0 {
            1
        } else {
            2
        };
        Some(PixelLobe {
            n,
            ni: hit.normal,
            ng: hit.ng,
            v,
            peak: 2.0 * cos_o * n - v,
            cos_o,
            a2,
            g_o,
            correlated,
            fresnel,
            ior: bsdf.ior,
            f0: bsdf.dielectric_f0(),
            cspec0: bsdf.cspec0,
            diffuse: bsdf.diffuse,
            roughness: bsdf.roughness,
            fv: (1.0 - cos_o).clamp(0.0, 1.0).powi(5),
            bump: n != hit.normal,
            ni_dot_n: hit.normal.dot(n),
        })
    }
}

/// `g(l)` of pixel `k` at unit direction `(x, y, z)`: [`super::shading::rough`]'s lobes, their tests
/// as selects; the pixel's choices (Smith term, Fresnel, diffuse lobe, bump shadowing) are constants
/// so that each combination compiles to its own straight loop.
#[inline(always)]
fn lobe<const CORRELATED: bool, const FRESNEL: u8, const DIFFUSE: bool, const BUMP: bool>(
    k: &PixelLobe,
    x: f64,
    y: f64,
    z: f64,
) -> f64 {
    let dot = |a: DVec3| a.x * x + a.y * y + a.z * z;
    let (ngl, nil, cos_i) = (dot(k.ng), dot(k.ni), dot(k.n));
    let lit = ngl > 0.0 && cos_i > 0.0;
    // GGX: the half vector, D, G and Fresnel (Principled::specular).
    let (hx, hy, hz) = (x + k.v.x, y + k.v.y, z + k.v.z);
    // As glam's `normalize`: times the reciprocal of the length.
    let inv = 1.0 / (hx * hx + hy * hy + hz * hz).sqrt();
    let (mx, my, mz) = (hx * inv, hy * inv, hz * inv);
    let noh = k.n.x * mx + k.n.y * my + k.n.z * mz;
    let t = noh * noh * (k.a2 - 1.0) + 1.0;
    let d = k.a2 / (PI * t * t);
    let g = if CORRELATED {
        let gv = cos_i * k.g_o;
        let gl = k.cos_o * (cos_i * cos_i * (1.0 - k.a2) + k.a2).sqrt();
        let s = gv + gl;
        let vis = if s > 0.0 { 0.5 / s } else { 0.0 };
        vis * 4.0 * k.cos_o * cos_i
    } else {
        k.g_o * (2.0 / (1.0 + (1.0 + k.a2 * (1.0 - cos_i * cos_i) / (cos_i * cos_i)).max(0.0).sqrt()))
    };
    let f = match FRESNEL {
        0 => k.cspec0,
        1 => 1.0,
        _ => {
            let fh = (dielectric(x * mx + y * my + z * mz, k.ior) - k.f0) / (1.0 - k.f0);
            k.cspec0 * (1.0 - fh) + fh
        }
    };
    let spec = d * g * f / (4.0 * k.cos_o);
    let spec = if lit && nil >= 0.0 { spec } else { 0.0 };
    if !DIFFUSE {
        return spec;
    }
    // Disney diffuse with its bump shadowing (Principled::disney_diffuse).
    let fl = (1.0 - cos_i).clamp(0.0, 1.0).powi(5);
    let rr = k.roughness * (dot(k.v) + 1.0);
    let fd = (1.0 - 0.5 * k.fv) * (1.0 - 0.5 * fl) + rr * (fl + k.fv + fl * k.fv * (rr - 1.0));
    let mut value = cos_i * fd / PI;
    if BUMP {
        let den = cos_i * k.ni_dot_n;
        let gb = if den != 0.0 { nil / den } else { 0.0 };
        let gb2 = gb * gb;
        let term = if gb >= 1.0 {
            1.0
        } else if gb < 0.0 {
            0.0
        } else {
            -gb2 * gb + gb2 + gb
        };
        value *= term;
    }
    spec + k.diffuse * if lit { value } else { 0.0 }
}

/// `reflectance_unpolarised(|c|, 1, ior)` for `ior > 1` (no total internal reflection), its
/// clamps as selects.
#[inline(always)]
fn dielectric(c: f64, ior: f64) -> f64 {
    let unit = |x: f64| if x.is_nan() { 1.0 } else { x.clamp(0.0, 1.0) };
    let c = c.abs().clamp(0.0, 1.0);
    let sin2_i = (1.0 - c * c).max(0.0);
    let ratio = 1.0 / ior;
    let sin2_t = ratio * ratio * sin2_i;
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_s = (c - ior * cos_t) / (c + ior * cos_t);
    let r_p = (ior * c - cos_t) / (ior * c + cos_t);
    unit(0.5 * (unit(r_s * r_s) + unit(r_p * r_p)))
}

/// One combination of the pixel's choices: the lobe over every node into `w`, then the sum in
/// [`LANES`] partial sums per channel.
#[inline(always)]
fn sum_with<const CORRELATED: bool, const FRESNEL: u8, const DIFFUSE: bool, const BUMP: bool>(
    k: &PixelLobe,
    cut: &FlatCut,
    w: &mut Vec<f64>,
) -> [f64; 3] {
    debug_assert!(cut.len().is_multiple_of(LANES), "a flat cut is padded to whole lanes");
    let n = cut.len() / LANES * LANES;
    w.clear();
    w.resize(n, 0.0);
    let (xs, ys, zs) = (&cut.x[..n], &cut.y[..n], &cut.z[..n]);
    for (((w, &x), &y), &z) in w.iter_mut().zip(xs).zip(ys).zip(zs) {
        *w = lobe::<CORRELATED, FRESNEL, DIFFUSE, BUMP>(k, x, y, z);
    }
    let mut acc = [[0.0f64; LANES]; 3];
    for (i, w) in w.chunks_exact(LANES).enumerate() {
        for (ch, p) in [&cut.r, &cut.g, &cut.b].into_iter().enumerate() {
            let p = &p[i * LANES..(i + 1) * LANES];
            for j in 0..LANES {
                acc[ch][j] += w[j] * p[j];
            }
        }
    }
    acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]))
}

/// [`sum`]'s body: the pixel's combination.
#[inline(always)]
fn sum_lanes(k: &PixelLobe, cut: &FlatCut, w: &mut Vec<f64>) -> [f64; 3] {
    macro_rules! pick {
        ($c:literal) => {
            match (k.fresnel, k.diffuse > 0.0, k.bump) {
                (0, false, _) => sum_with::<$c, 0, false, false>(k, cut, w),
                (1, false, _) => sum_with::<$c, 1, false, false>(k, cut, w),
                (_, false, _) => sum_with::<$c, 2, false, false>(k, cut, w),
                (0, true, false) => sum_with::<$c, 0, true, false>(k, cut, w),
                (1, true, false) => sum_with::<$c, 1, true, false>(k, cut, w),
                (_, true, false) => sum_with::<$c, 2, true, false>(k, cut, w),
                (0, true, true) => sum_with::<$c, 0, true, true>(k, cut, w),
                (1, true, true) => sum_with::<$c, 1, true, true>(k, cut, w),
                (_, true, true) => sum_with::<$c, 2, true, true>(k, cut, w),
            }
        };
    }
    if k.correlated {
        pick!(true)
    } else {
        pick!(false)
    }
}

cpu::dispatch! {
    #[levels(Avx2)]
    /// `sum g(l_i) P_i` over `cut` (padded, [`FlatCut::pad`]) for pixel `k`; `w` is scratch.
    #[inline(always)]
    pub fn sum(k: &PixelLobe, cut: &FlatCut, w: &mut Vec<f64>) -> [f64; 3] = sum_lanes;
}
