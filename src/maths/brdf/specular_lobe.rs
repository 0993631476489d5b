//! The lobes a specular chain is prefiltered with, and the roughness each level of the chain is
//! filtered for (the map an engine's shader inverts to pick a level).
//!
//! # Lobes (n = v, so n.h = v.h and the light direction `l = 2 (n.h) h - n` has pdf `D(h) / 4`)
//!
//! - `Ggx`: `D(h) = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)`, sampled as in `maths::brdf::ggx`.
//! - `Charlie`: the sheen distribution of Estevez and Kulla ("Production Friendly Microfacet Sheen
//!   BRDF", 2017), as glTF-IBL-Sampler's `filter.frag` evaluates it for its `charlie` chain:
//!   `D(h) = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)`, alpha = roughness^2 clamped to at
//!   least 1e-6, sampled with `sin(theta_h) = u^(alpha / (2 alpha + 1))`, `phi = 2 pi u'`,
//!   whose pdf is `D(h) cos(theta_h)`: `int D cos dh = 1` (`k = 1/alpha`:
//!   `(2 + k) int_0^(pi/2) sin^(k+1) cos = 1`; tested). The lobe grows towards grazing half
//!   vectors; with n = v only `theta_h < 45 degrees` reflects above the horizon, so at low
//!   roughness almost every sample is below it: the filtered level tends to black, as the
//!   sampler's does (its level 0 is black).
//!
//! # Roughness of level k of N (`RoughnessMap`)
//!
//! - `Linear`: `r = k / (N - 1)`, read back with `lod = r (N - 1)` (Bevy, glTF viewers).
//! - `Filament`: `r = 1 - sqrt(1 - k / (N - 1))`, cmgen's `lodToPerceptualRoughness`
//!   (`(sqrt(a^2 + 4 b lod) - a) / (2 b)`, a = 2, b = -1), the inverse of Filament's shader
//!   lookup `lod = (N - 1) r (2 - r)` (`perceptualRoughnessToLod`; tested both ways).
//! - `List`: the roughness of each level given explicitly.

use std::f64::consts::PI;

use glam::DVec3;

crate::choice! {
    /// The specular lobe.
    pub enum SpecularBrdf {
        /// GGX (Trowbridge-Reitz) with n = v = r
        Ggx,
        /// the Charlie sheen distribution (Estevez and Kulla 2017), as glTF-IBL-Sampler's charlie chain
        Charlie,
    }
}

crate::choice! {
    /// The perceptual roughness each level of a chain is filtered for.
    pub enum RoughnessMap {
        /// level k of N: k / (N - 1), read with lod = r (N - 1) (Bevy, Khronos glTF viewers)
        Linear,
        /// level k of N: 1 - sqrt(1 - k / (N - 1)), read with lod = (N - 1) r (2 - r) (Filament, cmgen)
        Filament,
        /// the list `roughness_list` gives each level's roughness
        List,
    }
}

/// The smallest alpha the Charlie lobe is evaluated with (glTF-IBL-Sampler's clamp).
const CHARLIE_MIN_ALPHA: f64 = 1e-6;

impl SpecularBrdf {
    /// `D(h)` as a function of `n.h` and alpha (= roughness^2).
    #[inline]
    pub fn d(self, noh: f64, alpha: f64) -> f64 {
        match self {
            SpecularBrdf::Ggx => crate::maths::brdf::ggx::d_ggx(noh, alpha),
            SpecularBrdf::Charlie => {
                let inv = 1.0 / alpha.max(CHARLIE_MIN_ALPHA);
                let sin2 = (1.0 - noh * noh).max(0.0);
                (2.0 + inv) * sin2.powf(0.5 * inv) / (2.0 * PI)
            }
        }
    }

    /// A half vector drawn with pdf `D(h) (n.h)`, in the frame where n = +z.
    #[inline]
    pub fn sample_h(self, u: [f64; 2], alpha: f64) -> DVec3 {
        match self {
            SpecularBrdf::Ggx => crate::maths::brdf::ggx::sample_h(u, alpha),
            SpecularBrdf::Charlie => {
                let a = alpha.max(CHARLIE_MIN_ALPHA);
                let sin_t = u[0].powf(a / (2.0 * a + 1.0)).min(1.0);
                let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
                let phi = 2.0 * PI * u[1];
                DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
            }
        }
    }
}

impl RoughnessMap {
    /// The perceptual roughness of level `k` of `levels` (0 for a single level); `List` reads
    /// `list[k]` (validation makes the list as long as the chain).
    pub fn roughness(self, k: usize, levels: usize, list: &[f64]) -> f64 {
        let lod = if levels <= 1 { 0.0 } else { k as f64 / (levels - 1) as f64 };
        match self {
            RoughnessMap::Linear => lod,
            RoughnessMap::Filament => lod_to_perceptual_roughness(lod),
            RoughnessMap::List => list.get(k).copied().unwrap_or(0.0),
        }
    }
}

/// cmgen's `lodToPerceptualRoughness(lod)`, lod in [0, 1] (a fraction of the last level):
/// `(sqrt(a^2 + 4 b lod) - a) / (2 b)` with a = 2, b = -1, saturated; 0 at lod 0.
pub fn lod_to_perceptual_roughness(lod: f64) -> f64 {
    let (a, b) = (2.0, -1.0);
    if lod == 0.0 {
        0.0
    } else {
        (((a * a + 4.0 * b * lod).max(0.0).sqrt() - a) / (2.0 * b)).clamp(0.0, 1.0)
    }
}

/// Filament's shader lookup as a fraction of the last level: `r (2 - r)`
/// (`perceptualRoughnessToLod` divided by `iblRoughnessOneLevel`).
pub fn perceptual_roughness_to_lod(r: f64) -> f64 {
    r * (2.0 - r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filament_map_inverts_cmgens_lod_to_roughness() {
        for i in 0..=100 {
            let lod = i as f64 / 100.0;
            let r = lod_to_perceptual_roughness(lod);
            assert!((perceptual_roughness_to_lod(r) - lod).abs() < 1e-12, "{lod}: {r}");
        }
        // cmgen's 5 levels (256 down to 16): roughness 0, 0.134, 0.293, 0.5, 1.
        let r: Vec<f64> = (0..5).map(|k| RoughnessMap::Filament.roughness(k, 5, &[])).collect();
        let want = [0.0, 1.0 - 0.75f64.sqrt(), 1.0 - 0.5f64.sqrt(), 0.5, 1.0];
        assert!(r.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12), "{r:?}");
        assert_eq!(RoughnessMap::Linear.roughness(2, 5, &[]), 0.5);
        assert_eq!(RoughnessMap::List.roughness(1, 3, &[0.0, 0.7, 1.0]), 0.7);
        assert_eq!(RoughnessMap::Filament.roughness(0, 1, &[]), 0.0);
    }

    /// `int D(h) (n.h) dh = 1` over the hemisphere for both lobes (midpoint rule in theta), and
    /// the sampler's histogram of cos(theta_h) follows that pdf.
    #[test]
    fn lobes_are_normalised_and_sampled_by_their_pdf() {
        for brdf in SpecularBrdf::ALL {
            for r in [0.3, 0.6, 1.0] {
                let alpha = r * r;
                let n = 200_000;
                let dt = 0.5 * PI / n as f64;
                let total: f64 = (0..n)
                    .map(|i| {
                        let t = (i as f64 + 0.5) * dt;
                        brdf.d(t.cos(), alpha) * t.cos() * t.sin() * 2.0 * PI * dt
                    })
                    .sum();
                assert!((total - 1.0).abs() < 1e-3, "{brdf} r {r}: {total}");
                // P(cos theta_h > 0.8) by sampling and by the pdf.
                let samples = 20_000;
                let hits = (0..samples)
                    .filter(|&i| {
                        let u = [(i as f64 + 0.5) / samples as f64, 0.25];
                        brdf.sample_h(u, alpha).z > 0.8
                    })
                    .count() as f64
                    / samples as f64;
                let cut = 0.8f64.acos();
                let m = 20_000;
                let want: f64 = (0..m)
                    .map(|i| {
                        let t = (i as f64 + 0.5) * cut / m as f64;
                        brdf.d(t.cos(), alpha) * t.cos() * t.sin() * 2.0 * PI * cut / m as f64
                    })
                    .sum();
                assert!((hits - want).abs() < 2e-3, "{brdf} r {r}: sampled {hits}, pdf {want}");
            }
        }
    }
}
