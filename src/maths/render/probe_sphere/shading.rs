//! The light a camera ray carries back from the sphere: the mirror's single reflection, and the
//! rough lobes summed over the environment's texels.
//!
//! At a hit with shading normal `N` (interpolated), triangle normal `Ng` and view `v` (towards the
//! camera), the closures use `n = ensure_valid_reflection(Ng, v, N)` ([`super::principled`]).
//! Light from `l` reaches the point only when `Ng . l > 0`: the sphere is convex, so a direction below
//! the triangle's plane runs into the sphere itself (Cycles' shadow ray is blocked).
//!
//! - **Mirror** (`alpha^2 <= 1e-7`, Cycles' singular GGX): the ray reflects to `r = 2 (n.v) n - v`
//!   and returns `F(n.v) L(r)`; nothing when `n.v <= 0` or `Ng . r <= 0` (Cycles' sampler rejects
//!   those).
//! - **Rough lobes**: `Lo = int L(l) [f_spec cos + diffuse f_d cos](l) dl` over `Ng . l > 0` and
//!   above the corrected normal's horizon, summed over the map's texels by [`TexelTree::sum`], refined
//!   around the specular lobe's peak (the mirror direction `r`) at the lobe's width `2 alpha`.

use glam::DVec3;

use super::mesh::Hit;
use super::principled::{ensure_valid_reflection, Principled};
use super::texel_tree::TexelTree;

/// The corrected normal the closures use at `hit` seen along `v`.
pub fn closure_normal(hit: &Hit, v: DVec3) -> DVec3 {
    if hit.normal == hit.ng {
        hit.normal
    } else {
        ensure_valid_reflection(hit.ng, v, hit.normal)
    }
}

/// A perfect mirror's reflection of `v` (unit, towards the camera) and its Fresnel weight: the
/// radiance back along `v` is the weight times the map's radiance along the reflection (none
/// when the reflection is rejected).
pub fn mirror_ray(bsdf: &Principled, hit: &Hit, v: DVec3) -> Option<(DVec3, f64)> {
    let n = closure_normal(hit, v);
    let cos_o = n.dot(v);
    if !(cos_o > 0.0) {
        return None;
    }
    let r = 2.0 * cos_o * n - v;
    if !(hit.ng.dot(r) > 0.0) {
        return None;
    }
    Some((r, bsdf.fresnel(cos_o)))
}

/// The rough lobes' radiance back along `v`, summed over `tree` (made for this material's lobe
/// width, [`lobe_width`]).
pub fn rough(tree: &TexelTree, bsdf: &Principled, hit: &Hit, v: DVec3) -> [f64; 3] {
    let n = closure_normal(hit, v);
    let cos_o = n.dot(v);
    if !(cos_o > 0.0) {
        return [0.0; 3];
    }
    let peak = 2.0 * cos_o * n - v;
    let g = |l: DVec3| {
        if !(hit.ng.dot(l) > 0.0) {
            return 0.0;
        }
        let spec = bsdf.specular(n, hit.normal, v, l);
        if bsdf.diffuse > 0.0 {
            spec + bsdf.diffuse * bsdf.disney_diffuse(n, hit.normal, v, l)
        } else {
            spec
        }
    };
    tree.sum(peak, [n, hit.ng], g)
}

/// The width the texel sum refines the specular lobe for: `2 alpha` radians.
pub fn lobe_width(bsdf: &Principled) -> f64 {
    2.0 * bsdf.alpha
}
