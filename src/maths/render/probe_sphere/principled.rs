//! The Principled BSDF (v1) as Cycles 3.4 evaluates it for the protocol's three materials: its
//! parameters reduced to what the closures read, the GGX lobe with Principled v1's Fresnel, the
//! Disney diffuse lobe, and the normal correction every closure of a triangle receives.
//! Sources are the Cycles kernel of Blender 3.4.1 (Debian's `blender` package ships it under
//! `/usr/share/blender/scripts/addons/cycles/source/kernel/`); file names below are relative to it.
//!
//! Every lobe returns `f cos_i`, the BSDF times the cosine of the light direction, as Cycles'
//! `bsdf_eval` does. Directions are unit vectors pointing away from the surface: `v` towards the
//! camera (Cycles' `I`), `l` towards the light (`omega_in`).
//!
//! - Parameters (`svm/closure.h`, `CLOSURE_BSDF_PRINCIPLED_ID`): diffuse weight
//!   `base (1 - metallic)`; specular weight 1; `alpha = roughness^2`;
//!   `ior = 2 / (1 - sqrt(0.08 specular)) - 1`; `cspec0 = 0.08 specular (1 - metallic) + base metallic`
//!   (`specular_tint` 0, as the scripts set it). The distribution is the node's default GGX, so the
//!   lobe is single-scattering at every roughness.
//! - Fresnel (`closure/bsdf_util.h` `interpolate_fresnel_color`): `F = cspec0 (1 - FH) + FH`,
//!   `FH = (F_d(l.m, ior) - F_d(1, ior)) / (1 - F_d(1, ior))` with the exact dielectric reflectance
//!   `F_d` ([`crate::maths::brdf::fresnel::reflectance_unpolarised`], the same function as Cycles'
//!   `fresnel_dielectric_cos` for `ior >= 1`; at `ior = 1` both are 0 off grazing, so `F = cspec0`).
//! - GGX (`closure/bsdf_microfacet.h`, `bsdf_microfacet_ggx_eval_reflect`, isotropic): with `m` the
//!   half vector, `D = alpha^2 / (pi cos^4 (alpha^2 + tan^2))` ([`ggx::d_ggx`], the same function),
//!   separable Smith `G = G1(v) G1(l)`, `G1(w) = 2 / (1 + sqrt(1 + alpha^2 tan^2(w)))`, and
//!   `f cos_i = F G D / (4 cos_o)`; zero unless `cos_i > 0` and `cos_o > 0` against the (corrected)
//!   normal, and unless `l` is above the interpolated normal (`bsdf_microfacet_ggx_eval` receives
//!   `sd->N` as its `Ng`). [`Smith::Correlated`] is Blender 3.5+'s `G = 1 / (1 + Lambda(v) +
//!   Lambda(l))` ([`ggx::v_smith_correlated`] times `4 cos_i cos_o`).
//! - Diffuse (`closure/bsdf_principled_diffuse.h`, `PRINCIPLED_DIFFUSE_FULL`):
//!   `f cos_i = (cos_i / pi) [(1 - FV/2)(1 - FL/2) + RR (FL + FV + FL FV (RR - 1))]`,
//!   `FL = (1 - cos_i)^5`, `FV = (1 - cos_o)^5`, `RR = roughness (1 + l.v)`; zero unless `cos_i > 0`;
//!   times `bump_shadowing_term` (`closure/bsdf.h`, `closure/bsdf_util.h`) when the corrected normal
//!   differs from the interpolated one.
//! - Normal correction (`svm/closure.h` line 105, `closure/bsdf_util.h` `ensure_valid_reflection`):
//!   on a triangle every closure's normal is bent towards the triangle's `Ng` just enough that the
//!   mirror direction of `v` is at least `min(0.9 Ng.v, 0.01)` above the triangle's plane.

use std::f64::consts::PI;

use glam::DVec3;

use crate::maths::brdf::fresnel::reflectance_unpolarised;
use crate::maths::brdf::ggx;

crate::choice! {
    /// The Smith masking-shadowing term of the GGX lobe.
    pub enum Smith {
        /// G1(v) G1(l), Cycles up to Blender 3.4 (Debian's Blender)
        Separable,
        /// 1 / (1 + Lambda(v) + Lambda(l)), Cycles from Blender 3.5 (the protocol's 3.6.5)
        Correlated,
    }
}

/// The closures of one Principled BSDF node as the protocol sets it (`specular_tint` 0,
/// anisotropy 0, no sheen, clearcoat, transmission or subsurface).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled {
    /// weight of the Disney diffuse lobe: `base (1 - metallic)`
    pub diffuse: f64,
    /// the diffuse lobe's roughness (the node's roughness itself)
    pub roughness: f64,
    /// GGX width, `roughness^2`
    pub alpha: f64,
    /// Fresnel's index, `2 / (1 - sqrt(0.08 specular)) - 1`
    pub ior: f64,
    /// Fresnel at normal incidence, `mix(0.08 specular, base, metallic)`
    pub cspec0: f64,
    pub smith: Smith,
    /// the dielectric reflectance at normal incidence, `F_d(1, ior)`
    f0: f64,
}

impl Principled {
    /// The node's inputs (grey base colour) as Cycles 3.4's `svm_node_closure_bsdf` turns them
    /// into closures.
    pub fn new(base: f64, metallic: f64, specular: f64, roughness: f64, smith: Smith) -> Principled {
        let metallic = metallic.clamp(0.0, 1.0);
        let ior = 2.0 / (1.0 - (0.08 * specular).max(0.0).sqrt()) - 1.0;
        Principled {
            diffuse: base * (1.0 - metallic),
            roughness,
            // `bsdf_microfacet_ggx_fresnel_setup` saturates alpha and cspec0.
            alpha: (roughness * roughness).clamp(0.0, 1.0),
            ior,
            cspec0: (0.08 * specular * (1.0 - metallic) + base * metallic).clamp(0.0, 1.0),
            smith,
            f0: reflectance_unpolarised(1.0, 1.0, ior),
        }
    }

    /// Whether the GGX lobe is a perfect mirror (`alpha^2 <= 1e-7`: Cycles' singular case).
    pub fn is_mirror(&self) -> bool {
        self.alpha * self.alpha <= 1e-7
    }

    /// The dielectric reflectance at normal incidence, `F_d(1, ior)`, that Fresnel's remap uses.
    pub fn dielectric_f0(&self) -> f64 {
        self.f0
    }

    /// Principled v1's Fresnel at `cos = l.m`.
    pub fn fresnel(&self, cos: f64) -> f64 {
        if self.ior == 1.0 {
            // F_d(., 1) = 0 (off grazing): the remapped Fresnel is cspec0 at every angle.
            return self.cspec0;
        }
        if self.f0 >= 1.0 {
            return 1.0;
        }
        let fh = (reflectance_unpolarised(cos.abs(), 1.0, self.ior) - self.f0) / (1.0 - self.f0);
        self.cspec0 * (1.0 - fh) + fh
    }

    /// The GGX lobe's `f cos_i` at normal `n` (corrected) and interpolated normal `n_interp`.
    pub fn specular(&self, n: DVec3, n_interp: DVec3, v: DVec3, l: DVec3) -> f64 {
        let (cos_o, cos_i) = (n.dot(v), n.dot(l));
        if n_interp.dot(l) < 0.0 || !(cos_i > 0.0 && cos_o > 0.0) || self.is_mirror() {
            return 0.0;
        }
        let m = (l + v).normalize();
        let d = ggx::d_ggx(n.dot(m), self.alpha);
        d * self.g(cos_o, cos_i) * self.fresnel(l.dot(m)) / (4.0 * cos_o)
    }

    /// The masking-shadowing term `G` at `cos_o`, `cos_i` (both > 0).
    pub fn g(&self, cos_o: f64, cos_i: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        match self.smith {
            Smith::Separable => {
                let g1 = |c: f64| 2.0 / (1.0 + (1.0 + a2 * (1.0 - c * c) / (c * c)).max(0.0).sqrt());
                g1(cos_o) * g1(cos_i)
            }
            Smith::Correlated => ggx::v_smith_correlated(cos_o, cos_i, self.alpha) * 4.0 * cos_o * cos_i,
        }
    }

    /// The Disney diffuse lobe's `f cos_i`, without its weight [`Principled::diffuse`].
    pub fn disney_diffuse(&self, n: DVec3, n_interp: DVec3, v: DVec3, l: DVec3) -> f64 {
        let cos_i = n.dot(l);
        if !(cos_i > 0.0) {
            return 0.0;
        }
        let schlick = |u: f64| (1.0 - u).clamp(0.0, 1.0).powi(5);
        let (fv, fl) = (schlick(n.dot(v)), schlick(cos_i));
        let rr = self.roughness * (l.dot(v) + 1.0);
        let f = (1.0 - 0.5 * fv) * (1.0 - 0.5 * fl) + rr * (fl + fv + fl * fv * (rr - 1.0));
        let value = cos_i * f / PI;
        if n == n_interp {
            value
        } else {
            value * bump_shadowing_term(n_interp, n, l)
        }
    }
}

/// Cycles' `bump_shadowing_term(Ng, N, I)` (`closure/bsdf_util.h`): the smooth fade a diffuse
/// closure whose normal `n` was changed from the shading normal `ng` receives.
pub fn bump_shadowing_term(ng: DVec3, n: DVec3, l: DVec3) -> f64 {
    let den = n.dot(l) * ng.dot(n);
    let g = if den != 0.0 { ng.dot(l) / den } else { 0.0 };
    if g >= 1.0 {
        1.0
    } else if g < 0.0 {
        0.0
    } else {
        let g2 = g * g;
        -g2 * g + g2 + g
    }
}

/// Cycles' `ensure_valid_reflection(Ng, I, N)` (`closure/bsdf_util.h`), in f64.
pub fn ensure_valid_reflection(ng: DVec3, v: DVec3, n: DVec3) -> DVec3 {
    let r = 2.0 * n.dot(v) * n - v;
    // Reflection rays may always be at least as shallow as the incoming ray.
    let threshold = (0.9 * ng.dot(v)).min(0.01);
    if ng.dot(r) >= threshold {
        return n;
    }
    // The frame: z = Ng, x the part of N orthogonal to it; solve for N' in the x-z plane with
    // dot(R', Ng) = threshold (the kernel's derivation, four roots of which two are positive).
    let x = (n - n.dot(ng) * ng).normalize_or_zero();
    let (ix, iz) = (v.dot(x), v.dot(ng));
    let (ix2, iz2) = (ix * ix, iz * iz);
    let a = ix2 + iz2;
    let b = (ix2 * (a - threshold * threshold)).max(0.0).sqrt();
    let c = iz * threshold + a;
    let fac = 0.5 / a;
    let (n1_z2, n2_z2) = (fac * (b + c), fac * (-b + c));
    let ok = |z2: f64| z2 > 1e-5 && z2 <= 1.0 + 1e-5;
    let (mut valid1, mut valid2) = (ok(n1_z2), ok(n2_z2));
    let pair = |z2: f64| ((1.0 - z2).max(0.0).sqrt(), z2.max(0.0).sqrt());
    let n_new = if valid1 && valid2 {
        let (n1, n2) = (pair(n1_z2), pair(n2_z2));
        let r1 = 2.0 * (n1.0 * ix + n1.1 * iz) * n1.1 - iz;
        let r2 = 2.0 * (n2.0 * ix + n2.1 * iz) * n2.1 - iz;
        valid1 = r1 >= 1e-5;
        valid2 = r2 >= 1e-5;
        if valid1 && valid2 {
            if r1 < r2 {
                n1
            } else {
                n2
            }
        } else if r1 > r2 {
            n1
        } else {
            n2
        }
    } else if valid1 || valid2 {
        pair(if valid1 { n1_z2 } else { n2_z2 })
    } else {
        return ng;
    };
    n_new.0 * x + n_new.1 * ng
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_protocols_materials_reduce_to_the_closures_the_docs_state() {
        let mirror = Principled::new(0.8, 1.0, 0.2, 0.0, Smith::Separable);
        assert!(mirror.is_mirror() && mirror.diffuse == 0.0);
        assert!((mirror.ior - 1.289_616_07).abs() < 1e-8, "{}", mirror.ior);
        // Normal incidence gives cspec0, grazing gives 1.
        assert!((mirror.fresnel(1.0) - 0.8).abs() < 1e-12);
        assert!((mirror.fresnel(0.0) - 1.0).abs() < 1e-12);
        let silver = Principled::new(0.8, 1.0, 0.0, 0.3271, Smith::Separable);
        assert!((silver.alpha - 0.106_994_41).abs() < 1e-8 && silver.ior == 1.0);
        for c in [0.05, 0.3, 0.7, 1.0] {
            assert!((silver.fresnel(c) - 0.8).abs() < 1e-12, "{c}");
        }
        let diffuse = Principled::new(0.8, 0.0, 0.5, 0.364, Smith::Separable);
        assert!((diffuse.ior - 1.5).abs() < 1e-12 && (diffuse.diffuse - 0.8).abs() < 1e-12);
        // With cspec0 = F0 the remapped Fresnel is the dielectric's own.
        for c in [0.1, 0.5, 0.9] {
            assert!((diffuse.fresnel(c) - reflectance_unpolarised(c, 1.0, 1.5)).abs() < 1e-12, "{c}");
        }
    }

    #[test]
    fn the_smith_terms_agree_at_normal_incidence_and_differ_towards_grazing() {
        let a = Principled::new(0.8, 1.0, 0.0, 0.5, Smith::Separable);
        let b = Principled { smith: Smith::Correlated, ..a };
        assert!((a.g(1.0, 1.0) - 1.0).abs() < 1e-12 && (b.g(1.0, 1.0) - 1.0).abs() < 1e-12);
        assert!(b.g(0.2, 0.2) > a.g(0.2, 0.2));
    }

    #[test]
    fn a_valid_reflection_is_left_alone_and_an_invalid_one_lifted_to_the_threshold() {
        let ng = DVec3::Z;
        let v = DVec3::new(0.6, 0.0, 0.8);
        assert_eq!(ensure_valid_reflection(ng, v, ng), ng);
        // A grazing view with a normal tilted away: the mirror direction would go below the plane.
        let v = DVec3::new(-0.995, 0.0, 0.1).normalize();
        let n = DVec3::new(0.3, 0.0, 1.0).normalize();
        assert!(ng.dot(2.0 * n.dot(v) * n - v) < 0.0);
        let fixed = ensure_valid_reflection(ng, v, n);
        let r = 2.0 * fixed.dot(v) * fixed - v;
        let threshold = (0.9 * ng.dot(v)).min(0.01);
        assert!((ng.dot(r) - threshold).abs() < 1e-9, "{}", ng.dot(r));
        assert!((fixed.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_diffuse_lobe_at_normal_view_and_light_is_one_over_pi_plus_retro_reflection() {
        // cos_i = cos_o = 1: FL = FV = 0, RR = 2 roughness, f = 1 (the retro term has FL = FV = 0).
        let p = Principled::new(0.8, 0.0, 0.5, 0.364, Smith::Separable);
        let v = p.disney_diffuse(DVec3::Z, DVec3::Z, DVec3::Z, DVec3::Z);
        assert!((v - 1.0 / PI).abs() < 1e-15);
    }
}
