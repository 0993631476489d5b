//! The GGX (Trowbridge-Reitz) microfacet lobe: its normal distribution, importance sampling,
//! Smith height-correlated visibility, and the split-sum DFG texture. Prefiltering a cube map
//! with it is [`crate::maths::ibl::prefilter`].
//!
//! Roughness: `roughness` is perceptual (Burley 2012; Karis 2013), `alpha = roughness^2`.
//!
//! - `D(h) = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)` (Walter et al. 2007, eq. 33).
//! - Sampling `h` with pdf `D(h) (n.h)`: `cos theta_h = sqrt((1 - u1) / (1 + (alpha^2 - 1) u1))`,
//!   `phi = 2 pi u2` (Karis 2013, `ImportanceSampleGGX`); the light direction `l = 2 (v.h) h - v`
//!   has pdf `D(h) (n.h) / (4 (v.h))`.
//! - Visibility, Smith height-correlated (Heitz 2014, eq. 99; Filament `V_SmithGGXCorrelated`):
//!   `V = 0.5 / (n.l sqrt((n.v)^2 (1 - alpha^2) + alpha^2) + n.v sqrt((n.l)^2 (1 - alpha^2) + alpha^2))`,
//!   `V = G / (4 n.l n.v)`.
//! - The DFG (split-sum) texture (Karis 2013; Filament `DFG.cpp`): with `v = (sqrt(1 - n.v^2), 0,
//!   n.v)`, `Gv = V 4 (n.l) (v.h) / (n.h)` (the sample weight `f cos / pdf` without Fresnel) and
//!   `Fc = (1 - v.h)^5`: single scattering stores `scale = E[(1 - Fc) Gv]`, `bias = E[Fc Gv]`, so
//!   `f0 scale + f90 bias` is the directional albedo with Schlick's Fresnel; the multiscatter form
//!   (Fdez-Aguera 2019, Filament's `MULTISCATTER` DFG) stores `E[Fc Gv]` and `E[Gv]`:
//!   `specular = mix(DFG.x, DFG.y, f0)`, and `1 - E[Gv]` is the energy that multiple scattering
//!   adds back (`1 + f0 (1 / E[Gv] - 1)` in the shader).

use std::f64::consts::PI;

use glam::DVec3;

use crate::maths::sampling::sequences::{radical_inverse, sobol_2d};

crate::choice! {
    /// The low-discrepancy points the lobe is sampled with.
    pub enum LobeSequence {
        /// the 2D Sobol sequence (unscrambled, Gray-code order)
        Sobol,
        /// Hammersley: (i / N, radical inverse of i in base 2)
        Hammersley,
    }
}

/// The first `n` points of `seq` in [0, 1)^2.
pub fn points(seq: LobeSequence, n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| match seq {
            LobeSequence::Sobol => sobol_2d(i as u32),
            LobeSequence::Hammersley => [i as f64 / n as f64, radical_inverse(i as u64, 2)],
        })
        .collect()
}

/// GGX `D` as a function of `n.h` and alpha.
#[inline]
pub fn d_ggx(noh: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let t = noh * noh * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// A half vector drawn with pdf `D(h) (n.h)`, in the frame where n = +z.
#[inline]
pub fn sample_h(u: [f64; 2], alpha: f64) -> DVec3 {
    let a2 = alpha * alpha;
    let cos_t = ((1.0 - u[0]) / (1.0 + (a2 - 1.0) * u[0])).max(0.0).sqrt();
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Smith height-correlated visibility `V = G2 / (4 n.l n.v)` (Heitz 2014, eq. 99).
#[inline]
pub fn v_smith_correlated(nov: f64, nol: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let gv = nol * (nov * nov * (1.0 - a2) + a2).sqrt();
    let gl = nov * (nol * nol * (1.0 - a2) + a2).sqrt();
    let d = gv + gl;
    if d > 0.0 {
        0.5 / d
    } else {
        0.0
    }
}

/// One DFG texel: (scale, bias), or (`E[Fc Gv]`, `E[Gv]`) for the multiscatter form, at `n.v` and
/// perceptual roughness.
pub fn dfg(nov: f64, roughness: f64, pts: &[[f64; 2]], multiscatter: bool) -> [f64; 2] {
    let alpha = roughness * roughness;
    let v = DVec3::new((1.0 - nov * nov).max(0.0).sqrt(), 0.0, nov);
    let (mut x, mut y) = (0.0, 0.0);
    for &u in pts {
        let h = sample_h(u, alpha);
        let voh = v.dot(h);
        let l = 2.0 * voh * h - v;
        let (nol, noh) = (l.z, h.z);
        if nol > 0.0 && voh > 0.0 && noh > 0.0 {
            let gv = v_smith_correlated(nov, nol, alpha) * 4.0 * nol * voh / noh;
            let fc = (1.0 - voh).powi(5);
            if multiscatter {
                x += gv * fc;
                y += gv;
            } else {
                x += gv * (1.0 - fc);
                y += gv * fc;
            }
        }
    }
    let n = pts.len().max(1) as f64;
    [x / n, y / n]
}

/// An orthonormal basis (t, b) around unit n (Duff et al., "Building an Orthonormal Basis,
/// Revisited", JCGT 2017).
#[inline]
pub fn basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dfg_smooth_limit() {
        // roughness -> 0: D is a delta at h = n, Gv -> 1: scale + bias -> 1, bias -> (1 - n.v)^5.
        let pts = points(LobeSequence::Hammersley, 256);
        for nov in [0.2, 0.5, 0.9] {
            let [a, b] = dfg(nov, 0.02, &pts, false);
            assert!((a + b - 1.0).abs() < 2e-3, "{nov}: {a} + {b}");
            assert!((b - (1.0 - nov).powi(5)).abs() < 2e-3, "{nov}: {b}");
        }
        // The multiscatter form's second channel is the single-scatter scale + bias.
        let [a, b] = dfg(0.5, 0.7, &pts, false);
        let [_, e] = dfg(0.5, 0.7, &pts, true);
        assert!((a + b - e).abs() < 1e-12);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [DVec3::X, DVec3::Y, -DVec3::Z, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let (t, b) = basis(n);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(n).abs() < 1e-12 && (t.cross(b) - n).length() < 1e-12);
        }
    }
}
