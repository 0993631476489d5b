//! Exact GGX sums over an environment's texels at any set of directions: the references an
//! engine's image-based lighting is compared with, pixel by pixel (tests/bevy_render.rs).
//!
//! With the texels `i` of [`Texels`] (direction `l_i`, solid angle `dOmega_i`, radiance `L_i`),
//! `alpha` the GGX width (perceptual roughness squared) and `D`, `V` of [`crate::maths::brdf::ggx`]:
//!
//! - [`prefiltered`]: the split-sum's first factor at `r` (Karis 2013, with `n = v = r`), the
//!   value a specular cube-map level holds: `sum L_i D(r.h_i) (r.l_i)+ dOmega_i / sum D(r.h_i)
//!   (r.l_i)+ dOmega_i`, `h_i = normalize(r + l_i)`. It is `prefilter_level_exact`'s ratio,
//!   evaluated at arbitrary directions of a lat-long map rather than at a cube's texels.
//! - [`specular`]: the single-scattering microfacet integral itself, without the split-sum
//!   approximation, `Lo(n, v) = sum L_i D(n.h_i) V(n.v, n.l_i) F(v.h_i) (n.l_i)+ dOmega_i`,
//!   `h_i = normalize(v + l_i)`, Smith height-correlated `V` and Schlick's
//!   `F = f0 + (1 - f0) (1 - v.h)^5` (the terms of the DFG texture, `ggx::dfg`). Under a
//!   constant map of radiance 1 it is the directional albedo `f0 scale + bias` of that texture
//!   (tested, to the midpoint rule).
//!
//! Both are midpoint-rule sums over texel centres (as [`crate::maths::render::reference`]): accurate
//! while the lobe spans several texels; a lobe narrower than a texel (alpha below a few texel
//! angles) is undersampled, so downsample no further than that. f64 throughout. Cost:
//! O(directions x texels), rayon over directions.

use glam::DVec3;
use rayon::prelude::*;

use crate::maths::brdf::ggx::{d_ggx, v_smith_correlated};
use crate::maths::ibl::irradiance_cube::Texels;

/// The prefiltered radiance at each unit direction of `dirs` (see the module documentation);
/// black where no texel has positive weight.
pub fn prefiltered(texels: &Texels, dirs: &[DVec3], alpha: f64) -> Vec<[f64; 3]> {
    dirs.par_iter()
        .map(|&r| {
            let mut acc = [0.0f64; 3];
            let mut total = 0.0;
            texels.for_each(|l, omega, v| {
                let rol = r.dot(l);
                if rol > 0.0 {
                    let w = d_ggx(r.dot((r + l).normalize()), alpha) * rol * omega;
                    for k in 0..3 {
                        acc[k] += v[k] * w;
                    }
                    total += w;
                }
            });
            if total > 0.0 {
                acc.map(|a| a / total)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// The single-scattering GGX radiance reflected towards `views[p]` at normal `normals[p]`, for
/// every p (unit vectors; see the module documentation), with Schlick's Fresnel of `f0` per
/// channel. 0 where `n.v <= 0`.
pub fn specular(texels: &Texels, normals: &[DVec3], views: &[DVec3], alpha: f64, f0: [f64; 3]) -> Vec<[f64; 3]> {
    normals
        .par_iter()
        .zip(views.par_iter())
        .map(|(&n, &v)| {
            let nov = n.dot(v);
            let mut acc = [0.0f64; 3];
            if nov <= 0.0 {
                return acc;
            }
            texels.for_each(|l, omega, rad| {
                let nol = n.dot(l);
                if nol > 0.0 {
                    let h = (v + l).normalize();
                    let fc = (1.0 - v.dot(h).clamp(0.0, 1.0)).powi(5);
                    let w = d_ggx(n.dot(h), alpha) * v_smith_correlated(nov, nol, alpha) * nol * omega;
                    for k in 0..3 {
                        acc[k] += rad[k] * w * (f0[k] + (1.0 - f0[k]) * fc);
                    }
                }
            });
            acc
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::brdf::ggx::{dfg, points, LobeSequence};
    use crate::values::Image;

    fn constant(w: usize, h: usize) -> Image {
        Image::from_fn_rgb(w, h, |_, _| [1.0, 1.0, 1.0])
    }

    #[test]
    fn white_furnace_prefiltered_is_one() {
        let env = constant(128, 64);
        let t = Texels::from_latlong(&env);
        let dirs = [DVec3::Y, DVec3::X, DVec3::new(0.3, -0.4, 0.866).normalize()];
        for alpha in [0.1, 0.5, 1.0] {
            for p in prefiltered(&t, &dirs, alpha) {
                assert!(p.iter().all(|&c| (c - 1.0).abs() < 1e-12), "alpha {alpha}: {p:?}");
            }
        }
    }

    /// Under radiance 1 the integral is the directional albedo `f0 scale + bias` of the DFG
    /// texture (estimated there with 4096 Sobol points).
    #[test]
    fn constant_map_gives_the_dfg_albedo() {
        let env = constant(512, 256);
        let t = Texels::from_latlong(&env);
        let pts = points(LobeSequence::Sobol, 4096);
        let n = DVec3::new(0.2, 0.9, -0.3).normalize();
        let (tx, _) = crate::maths::brdf::ggx::basis(n);
        let mut worst = 0.0f64;
        for roughness in [0.5f64, 0.75, 1.0] {
            for nov in [1.0f64, 0.7, 0.3] {
                let v = n * nov + tx * (1.0 - nov * nov).sqrt();
                let [scale, bias] = dfg(nov, roughness, &pts, false);
                for f0 in [1.0, 0.04] {
                    let got = specular(&t, &[n], &[v], roughness * roughness, [f0; 3])[0][0];
                    let want = f0 * scale + bias;
                    worst = worst.max((got / want - 1.0).abs());
                    // The midpoint rule on a 0.7-degree grid, against a 4096-point estimate.
                    assert!((got / want - 1.0).abs() < 2e-3, "r {roughness} n.v {nov} f0 {f0}: {got} vs {want}");
                }
            }
        }
        eprintln!("GGX integral under radiance 1 against the DFG albedo: worst relative difference {worst:.1e}");
    }

    #[test]
    fn back_facing_view_is_black() {
        let env = constant(16, 8);
        let t = Texels::from_latlong(&env);
        assert_eq!(specular(&t, &[DVec3::Y], &[-DVec3::Y], 0.5, [1.0; 3]), vec![[0.0; 3]]);
    }
}
