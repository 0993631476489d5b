//! The rough lobes of one pixel summed over a flat list of directions and powers (a tile's cut of
//! the texel tree, [`super::tile_cut`]): `sum_i g(l_i) P_i`, `g` the lobes of [`super::shading::rough`]
//! (`f_spec cos + diffuse f_d cos` where `Ng . l > 0`, 0 elsewhere).
//!
//! The list is structure of arrays, padded to a multiple of [`LANES`] with zero-power entries at
//! the zero direction (masked: `Ng . 0 = 0`), so the body is one branch-free loop over the nodes
//! that the compiler vectorises (single precision, eight lanes with AVX2); every test of the scalar
//! lobes (`Principled::specular`, `disney_diffuse`, `bump_shadowing_term`) is a select here, whose
//! discarded lane may hold a NaN (at `l = -v`, where the half vector vanishes) that never reaches
//! the sum. The sum runs in [`LANES`] partial sums per channel, added in a fixed order at the end,
//! so the result is the same bits at every level (`cpu::dispatch!`, no fused multiply-add;
//! tested). Single precision because the sum is the render's whole cost and the texel tree's cut
//! already errs by 0.1-0.7% (the operator states it): against the scalar f64 lobes summed in the
//! tree's order the sum differs by at most 1e-5 relative (tested).

use std::f64::consts::PI;

use glam::DVec3;

use super::principled::{Principled, Smith};
use super::shading::closure_normal;
use super::Hit;
use crate::cpu;

/// The nodes evaluated together; the list's length is a multiple of it.
pub const LANES: usize = 8;

/// A flat cut: node `i` is the direction `(x[i], y[i], z[i])` (unit, Blender's axes) carrying the
/// power `(r[i], g[i], b[i])`.
#[derive(Default)]
pub struct FlatCut {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub z: Vec<f32>,
    pub r: Vec<f32>,
    pub g: Vec<f32>,
    pub b: Vec<f32>,
}

impl FlatCut {
    pub fn clear(&mut self) {
        for v in [&mut self.x, &mut self.y, &mut self.z, &mut self.r, &mut self.g, &mut self.b] {
            v.clear();
        }
    }

    pub fn push(&mut self, d: DVec3, p: [f64; 3]) {
        self.x.push(d.x as f32);
        self.y.push(d.y as f32);
        self.z.push(d.z as f32);
        self.r.push(p[0] as f32);
        self.g.push(p[1] as f32);
        self.b.push(p[2] as f32);
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

/// One pixel's lobes: the directions the tile's cones bound ([`super::tile_cut`]) and the
/// kernel's constants.
#[derive(Clone, Copy, Debug)]
pub struct PixelLobe {
    /// the corrected normal the closures use
    pub n: DVec3,
    /// the triangle's normal
    pub ng: DVec3,
    /// the specular lobe's peak, the mirror direction of `v` about `n`
    pub peak: DVec3,
    correlated: bool,
    /// Fresnel: 0 the constant `cspec0`, 1 the constant 1, 2 the remapped dielectric
    fresnel: u8,
    /// whether `n` differs from the interpolated normal (the diffuse lobe's bump shadowing applies)
    bump: bool,
    lanes: Lanes,
}

/// A pixel's constants in single precision, as the kernel reads them.
#[derive(Clone, Copy, Debug)]
struct Lanes {
    n: [f32; 3],
    /// the interpolated (shading) normal
    ni: [f32; 3],
    ng: [f32; 3],
    /// towards the camera
    v: [f32; 3],
    cos_o: f32,
    a2: f32,
    /// separable Smith: `G1(cos_o)`; correlated: `sqrt(cos_o^2 (1 - a2) + a2)`
    g_o: f32,
    /// `alpha^2 / (4 pi cos_o)`: `D G F / (4 cos_o)` is `spec_scale |h|^4 G F / t^2`
    spec_scale: f32,
    ior: f32,
    /// Fresnel 2: `F = fresnel_base + fresnel_slope F_d(l.m)`
    fresnel_base: f32,
    fresnel_slope: f32,
    cspec0: f32,
    diffuse: f32,
    roughness: f32,
    /// the diffuse lobe's `(1 - cos_o)^5`
    fv: f32,
    ni_dot_n: f32,
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
        let f0 = bsdf.dielectric_f0();
        let fresnel = if bsdf.ior == 1.0 {
            0
        } else if f0 >= 1.0 {
            1
        } else {
            2
        };
        // F = cspec0 (1 - FH) + FH, FH = (F_d - f0) / (1 - f0): linear in F_d.
        let slope = if fresnel == 2 { (1.0 - bsdf.cspec0) / (1.0 - f0) } else { 0.0 };
        let v3 = |d: DVec3| [d.x as f32, d.y as f32, d.z as f32];
        let lanes = Lanes {
            n: v3(n),
            ni: v3(hit.normal),
            ng: v3(hit.ng),
            v: v3(v),
            cos_o: cos_o as f32,
            a2: a2 as f32,
            g_o: g_o as f32,
            spec_scale: (a2 / (4.0 * PI * cos_o)) as f32,
            ior: bsdf.ior as f32,
            fresnel_base: (bsdf.cspec0 - slope * f0) as f32,
            fresnel_slope: slope as f32,
            cspec0: bsdf.cspec0 as f32,
            diffuse: bsdf.diffuse as f32,
            roughness: bsdf.roughness as f32,
            fv: (1.0 - cos_o).clamp(0.0, 1.0).powi(5) as f32,
            ni_dot_n: hit.normal.dot(n) as f32,
        };
        Some(PixelLobe { n, ng: hit.ng, peak: 2.0 * cos_o * n - v, correlated, fresnel, bump: n != hit.normal, lanes })
    }
}

/// `g(l)` of a pixel at unit direction `(x, y, z)`: [`super::shading::rough`]'s lobes in single
/// precision, their tests as selects; the pixel's choices (Smith term, Fresnel, diffuse lobe, bump
/// shadowing) are constants so that each combination compiles to its own straight loop.
///
/// The scalar lobes' divisions and square roots are gathered, with the same values in exact
/// arithmetic: the half vector `h = l + v` is not normalised (`t = (|h x n|^2 + alpha^2 (n.h)^2) /
/// |h|^2`, `l.m = |h| / 2`, `1 + l.v = |h|^2 / 2`);
/// `G1(l) = 2 cos_i / (cos_i + sqrt(cos_i^2 + alpha^2 (1 - cos_i^2)))` (the scalar form times
/// `cos_i / cos_i`); the dielectric reflectance is `(A^2 B^2 + C^2 D^2) / (2 D^2 B^2)` of its two
/// ratios `A / D`, `C / B`, whose clamps never act for `ior > 1`. So the specular lobe takes one
/// division and three square roots.
#[inline(always)]
fn lobe<const CORRELATED: bool, const FRESNEL: u8, const DIFFUSE: bool, const BUMP: bool>(
    k: &Lanes,
    x: f32,
    y: f32,
    z: f32,
) -> f32 {
    let dot = |a: [f32; 3]| a[0] * x + a[1] * y + a[2] * z;
    let (ngl, nil, cos_i) = (dot(k.ng), dot(k.ni), dot(k.n));
    let lit = ngl > 0.0 && cos_i > 0.0;
    // GGX: D = alpha^2 |h|^4 / (pi t_num^2), t_num = |h|^2 - (1 - alpha^2) (n.h)^2, taken as
    // |h x n|^2 + alpha^2 (n.h)^2: the difference cancels at the peak (to 1e-5 in single
    // precision), the sum does not. |h|^2 and n.h from h itself: `2 + 2 l.v` cancels where the
    // view grazes and the peak nears -v.
    let (h, n) = ([x + k.v[0], y + k.v[1], z + k.v[2]], k.n);
    let hh = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
    let nh = h[0] * n[0] + h[1] * n[1] + h[2] * n[2];
    let cross = [h[1] * n[2] - h[2] * n[1], h[2] * n[0] - h[0] * n[2], h[0] * n[1] - h[1] * n[0]];
    let t_num = cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2] + k.a2 * nh * nh;
    // G without its division: G = g_num / g_den.
    let (g_num, g_den) = if CORRELATED {
        let s = cos_i * k.g_o + k.cos_o * (cos_i * cos_i * (1.0 - k.a2) + k.a2).sqrt();
        (2.0 * k.cos_o * cos_i, s)
    } else {
        (k.g_o * 2.0 * cos_i, cos_i + (cos_i * cos_i + k.a2 * (1.0 - cos_i * cos_i)).sqrt())
    };
    // Fresnel F = f_num / f_den.
    let (f_num, f_den) = match FRESNEL {
        0 => (k.cspec0, 1.0),
        1 => (1.0, 1.0),
        _ => {
            // l.m = (1 + l.v) / |h| = |h| / 2.
            let c = (0.5 * hh.sqrt()).min(1.0);
            let sin2_t = (1.0 - 0.25 * hh).max(0.0) / (k.ior * k.ior);
            let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
            let (a, d) = (c - k.ior * cos_t, c + k.ior * cos_t);
            let (cc, b) = (k.ior * c - cos_t, k.ior * c + cos_t);
            let (num, den) = (a * a * b * b + cc * cc * d * d, 2.0 * d * d * b * b);
            (k.fresnel_base * den + k.fresnel_slope * num, den)
        }
    };
    let spec = k.spec_scale * hh * hh * g_num * f_num / (t_num * t_num * g_den * f_den);
    let spec = if lit && nil >= 0.0 { spec } else { 0.0 };
    if !DIFFUSE {
        return spec;
    }
    // Disney diffuse with its bump shadowing (Principled::disney_diffuse).
    let fl = (1.0 - cos_i).clamp(0.0, 1.0);
    let fl = fl * fl * fl * fl * fl;
    let rr = k.roughness * 0.5 * hh;
    let fd = (1.0 - 0.5 * k.fv) * (1.0 - 0.5 * fl) + rr * (fl + k.fv + fl * k.fv * (rr - 1.0));
    let mut value = cos_i * fd * std::f32::consts::FRAC_1_PI;
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

/// One combination of the pixel's choices: the lobe over [`LANES`] nodes at a time, summed in
/// [`LANES`] partial sums per channel, added in f64 in a fixed order at the end.
#[inline(always)]
fn sum_with<const CORRELATED: bool, const FRESNEL: u8, const DIFFUSE: bool, const BUMP: bool>(
    k: &PixelLobe,
    cut: &FlatCut,
) -> [f64; 3] {
    debug_assert!(cut.len().is_multiple_of(LANES), "a flat cut is padded to whole lanes");
    let lanes = &k.lanes;
    let n = cut.len() / LANES * LANES;
    let chunk = |v: &[f32], i: usize| -> [f32; LANES] {
        let mut out = [0.0; LANES];
        out.copy_from_slice(&v[i * LANES..(i + 1) * LANES]);
        out
    };
    let mut acc = [[0.0f32; LANES]; 3];
    for i in 0..n / LANES {
        let (xs, ys, zs) = (chunk(&cut.x, i), chunk(&cut.y, i), chunk(&cut.z, i));
        let mut w = [0.0f32; LANES];
        for j in 0..LANES {
            w[j] = lobe::<CORRELATED, FRESNEL, DIFFUSE, BUMP>(lanes, xs[j], ys[j], zs[j]);
        }
        for (ch, p) in [&cut.r, &cut.g, &cut.b].into_iter().enumerate() {
            let p = chunk(p, i);
            for j in 0..LANES {
                acc[ch][j] += w[j] * p[j];
            }
        }
    }
    acc.map(|a| a.iter().fold(0.0f64, |s, &v| s + v as f64))
}

/// [`sum`]'s body: the pixel's combination.
#[inline(always)]
fn sum_lanes(k: &PixelLobe, cut: &FlatCut) -> [f64; 3] {
    macro_rules! pick {
        ($c:literal) => {
            match (k.fresnel, k.lanes.diffuse > 0.0, k.bump) {
                (0, false, _) => sum_with::<$c, 0, false, false>(k, cut),
                (1, false, _) => sum_with::<$c, 1, false, false>(k, cut),
                (_, false, _) => sum_with::<$c, 2, false, false>(k, cut),
                (0, true, false) => sum_with::<$c, 0, true, false>(k, cut),
                (1, true, false) => sum_with::<$c, 1, true, false>(k, cut),
                (_, true, false) => sum_with::<$c, 2, true, false>(k, cut),
                (0, true, true) => sum_with::<$c, 0, true, true>(k, cut),
                (1, true, true) => sum_with::<$c, 1, true, true>(k, cut),
                (_, true, true) => sum_with::<$c, 2, true, true>(k, cut),
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
    /// `sum g(l_i) P_i` over `cut` (padded, [`FlatCut::pad`]) for pixel `k`.
    #[inline(always)]
    pub fn sum(k: &PixelLobe, cut: &FlatCut) -> [f64; 3] = sum_lanes;
}
