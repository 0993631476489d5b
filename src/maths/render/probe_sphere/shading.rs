//! The light a camera ray carries back from the sphere: the mirror's single reflection, and the
//! rough lobes integrated over the environment by a fixed quadrature.
//!
//! At a hit with shading normal `N` (interpolated), triangle normal `Ng` and view `v` (towards the
//! camera), the closures use `n = ensure_valid_reflection(Ng, v, N)` ([`super::principled`]).
//! Light from `l` reaches the point only when `Ng . l > 0`: the sphere is convex, so a direction below
//! the triangle's plane runs into the sphere itself (Cycles' shadow ray is blocked).
//!
//! - **Mirror** (`alpha^2 <= 1e-7`, Cycles' singular GGX): the ray reflects to `r = 2 (n.v) n - v`
//!   and returns `F(n.v) L(r)`; nothing when `n.v <= 0` or `Ng . r <= 0` (Cycles' sampler rejects
//!   those).
//! - **Rough lobes**: `Lo = int L(l) [f_spec cos + diffuse f_d cos](l) dl` over `Ng . l > 0`,
//!   estimated with the same `N` points `u_i` of a 2D Hammersley set at every shading point
//!   (deterministic, no noise from pixel to pixel): the specular lobe by half vectors drawn with
//!   density `D(h) (n.h)` ([`ggx::sample_h`]), so that `l = 2 (v.h) h - v` has density
//!   `p = D (n.h) / (4 v.h)` and weight `f cos / p = F G (v.h) / ((n.v)(n.h))`; the diffuse lobe by
//!   cosine-distributed directions (Malley's method, `p = (n.l) / pi`). Each `L(l)` is the
//!   environment's filtered value over the sample's share of the sphere, `Omega_s = 1 / (N p)`, at
//!   `lod = 0.5 log2(Omega_s / Omega_texel)` (filtered importance sampling; Krivanek and Colbert
//!   2008, eq. 4 with no bias term): this smooths the fixed pattern's aliasing on small bright
//!   sources and tends to Cycles' bilinear lookup as `N` grows. The operator's tests state the
//!   error of its default `N` against `16 N`.

use std::f64::consts::PI;

use glam::DVec3;

use super::environment::Environment;
use super::mesh::Hit;
use super::principled::{ensure_valid_reflection, Principled};
use crate::maths::brdf::ggx;

/// The fixed lobe quadrature: `N` Hammersley points.
pub struct Quadrature {
    points: Vec<[f64; 2]>,
}

impl Quadrature {
    pub fn new(samples: usize) -> Quadrature {
        Quadrature { points: ggx::points(ggx::LobeSequence::Hammersley, samples.max(1)) }
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// The corrected normal the closures use at `hit` seen along `v`.
pub fn closure_normal(hit: &Hit, v: DVec3) -> DVec3 {
    if hit.normal == hit.ng {
        hit.normal
    } else {
        ensure_valid_reflection(hit.ng, v, hit.normal)
    }
}

/// A perfect mirror's radiance back along `v` (unit, towards the camera).
pub fn mirror(env: &Environment, bsdf: &Principled, hit: &Hit, v: DVec3) -> [f64; 3] {
    let n = closure_normal(hit, v);
    let cos_o = n.dot(v);
    if !(cos_o > 0.0) {
        return [0.0; 3];
    }
    let r = 2.0 * cos_o * n - v;
    if !(hit.ng.dot(r) > 0.0) {
        return [0.0; 3];
    }
    let f = bsdf.fresnel(cos_o);
    env.cycles(r).map(|c| f * c)
}

/// The rough lobes' radiance back along `v`, integrated with `quad`.
pub fn rough(env: &Environment, bsdf: &Principled, hit: &Hit, v: DVec3, quad: &Quadrature) -> [f64; 3] {
    let n = closure_normal(hit, v);
    let cos_o = n.dot(v);
    let mut acc = [0.0; 3];
    if !(cos_o > 0.0) {
        return acc;
    }
    let (t, b) = ggx::basis(n);
    let count = quad.points.len() as f64;
    let mut add = |l: DVec3, weight: f64, pdf: f64| {
        if !(weight > 0.0) {
            return;
        }
        let theta = l.z.clamp(-1.0, 1.0).acos();
        let lod = 0.5 * (1.0 / (count * pdf) / env.texel_solid_angle(theta)).log2();
        let radiance = env.filtered(l, lod);
        for c in 0..3 {
            acc[c] += weight * radiance[c];
        }
    };
    if !bsdf.is_mirror() {
        for &u in &quad.points {
            let hl = ggx::sample_h(u, bsdf.alpha);
            let h = t * hl.x + b * hl.y + n * hl.z;
            let voh = v.dot(h);
            if !(voh > 0.0) {
                continue;
            }
            let l = 2.0 * voh * h - v;
            let cos_i = n.dot(l);
            if !(cos_i > 0.0) || !(hit.ng.dot(l) > 0.0) || hit.normal.dot(l) < 0.0 {
                continue;
            }
            let noh = hl.z;
            let weight = bsdf.fresnel(voh) * bsdf.g(cos_o, cos_i) * voh / (cos_o * noh);
            let pdf = ggx::d_ggx(noh, bsdf.alpha) * noh / (4.0 * voh);
            add(l, weight, pdf);
        }
    }
    if bsdf.diffuse > 0.0 {
        for &[u1, u2] in &quad.points {
            // Malley's method: a point uniform on the disc lifted to the hemisphere.
            let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
            let z = (1.0 - u1).max(0.0).sqrt();
            let l = t * (r * phi.cos()) + b * (r * phi.sin()) + n * z;
            if !(z > 0.0) || !(hit.ng.dot(l) > 0.0) {
                continue;
            }
            let pdf = z / PI;
            add(l, bsdf.diffuse * bsdf.disney_diffuse(n, hit.normal, v, l) / pdf, pdf);
        }
    }
    acc.map(|a| a / count)
}
