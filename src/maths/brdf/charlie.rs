//! The Charlie (sheen) LUT the Khronos glTF Sample Viewer reads for image-based sheen, computed
//! as glTF-IBL-Sampler's `LUT()` computes it for its Charlie distribution.
//!
//! # What the viewer reads
//!
//! `getIBLRadianceCharlie` (glTF-Sample-Renderer `source/Renderer/shaders/ibl.glsl`, read at
//! 4e170c47f29a888055115a9b52cc9dc765c94cd3; glTF-Sample-Viewer's older copy at
//! 0120a8ebc5019c03509aac48772cba23a582d387 reads the LUT the same way):
//! `sheen = textureLod(u_CharlieEnvSampler, r, lod).rgb * sheenColor * texture(u_CharlieLUT,
//! vec2(n.v, sheenRoughness)).b`: the **blue** channel, unscaled, bilinear with clamp to edge,
//! s = n.v, t = sheen roughness (perceptual; t = 0 is the first row of the texture, the top row of
//! a PNG). Separately, the albedo scaling of the layers below the sheen reads `.r` of another
//! texture, `lut_sheen_E.png` (`albedoSheenScalingLUT`, `pbr.frag` at
//! 07d2ba65f656af7581e8ef3c86967db241897db0): that one is not computed here.
//!
//! # What glTF-IBL-Sampler writes
//!
//! `lib/source/shaders/filter.frag` (KhronosGroup/glTF-IBL-Sampler at
//! 08fa12250f6f5f5969c1846aaa266e6eea887731), `LUT(NdotV, roughness)` with
//! `distribution == cCharlie`, evaluated at texel centres, `LUT(inUV.x, inUV.y)` with
//! `inUV = (x + 0.5, y + 0.5) / S` (`primitive.vert`; Vulkan's framebuffer row 0 is `inUV.y`
//! near 0, so row 0 is roughness 0: the top row). `lib/source/lib.cpp` `sample()` renders it into
//! an `R8G8B8A8_UNORM` target the size of the cube's level 0 and `download2DImage` writes it as an
//! 8-bit RGB PNG with (R, G, B) = (0, 0, value); the CLI's default is 1024 samples
//! (`cli/source/cli.cpp`). The Sample Viewer ships a file of that name,
//! `assets/images/lut_charlie.png` (how it was made is not recorded beside it, and its pixels
//! are not compared here); its current renderer computes the texture at load time with the same
//! `LUT()`
//! (glTF-Sample-Renderer `source/shaders/ibl_filtering.frag` at
//! 4c87bce87b43dd85dd4b7133bfdb638ee2be34a8; `source/ibl_sampler.js` at
//! 029f5c9fd21c9c4a0466a3587e44b945a6315f82, `sampleCharlieLut`: 512 samples, 1024 x 1024).
//!
//! The estimate, with `N` Hammersley points `xi_i = (i / N, radical inverse of i in base 2)`:
//!
//! ```text
//! LUT(n.v, r) = (8 pi / N) sum_{i : n.l_i > 0} D(h_i; r) V_A(n.l_i, n.v) (n.l_i) (v.h_i)
//!
//! v       = (sqrt(1 - n.v^2), 0, n.v),  n = +z
//! h_i     : sin(theta_h) = xi_i.y ^ (b / (2 b + 1)),  phi_h = 2 pi xi_i.x,  b = r^2
//!           (the sampler's `Charlie(xi, roughness)`: pdf p(h) = D(h; r^2) (n.h))
//! l_i     = 2 (v.h_i) h_i - v
//! D(h; a) = (2 + 1/a) sin(theta_h)^(1/a) / (2 pi),  a clamped to at least 1e-6
//!           (Estevez and Kulla, "Production Friendly Microfacet Sheen BRDF", 2017; `D_Charlie`)
//! V_A     = clamp(1 / (4 (n.l + n.v - n.l n.v)), 0, 1)
//!           (Ashikhmin's visibility as Filament's `visibilityAshikhmin`; `V_Ashikhmin`)
//! ```
//!
//! n.l, n.h and v.h are clamped to [0, 1] as the shader's `saturate` does. The sampler's
//! frame for n = +z (`generateTBN`) is the identity, so `h` is used as drawn.
//!
//! # What the estimate converges to, and where it departs from the sheen albedo
//!
//! As N grows the sum tends to
//!
//! ```text
//! I(n.v, r) = 8 pi int_H D(h; r) V_A (n.l)+ (v.h)+ p(h) dh,   p(h) = D(h; r^2) (n.h)
//! ```
//!
//! The factor `8 pi = 4 * 2 pi` is the Jacobian `dl = 4 (v.h) dh` times `1 / p` for half vectors
//! drawn uniformly (`p = 1 / (2 pi)`), as the shader's closing comment derives it; but its half
//! vectors follow `p(h) = D(h; r^2) (n.h)`, and its `D` takes the perceptual roughness itself as
//! alpha where the viewer's punctual sheen (`brdf.glsl` `D_Charlie`) squares it. So `I` is not the
//! directional albedo `E = 4 int_H D(h; r^2) V_A (n.l)+ (v.h) dh` of the viewer's lobe: at n.v = 1
//! and r = 1 (where `V_A = 1/4`, `n.l = cos 2 theta_h`) both have closed forms,
//! `I = 9 int_0^(pi/4) sin^3 cos^2 cos(2 theta) dtheta = 3 (11 / sqrt 2 - 4) / 70 = 0.161922` and
//! `E = 3 int_0^(pi/4) sin^2 cos cos(2 theta) dtheta = sqrt(2) / 10 = 0.141421` (tested). hdrflow
//! writes the sampler's `I`, not `E`: it is what the viewer multiplies its sheen by when it makes
//! the table itself, so `E` would render differently from the viewer's own.
//!
//! # Values above 1
//!
//! `I` exceeds 1 in the corner of grazing views and low roughness (half vectors drawn near the
//! horizon, where `D(h; r)` is large and `V_A` is clamped to 1): in a 128 x 128 table of 1024
//! samples, 516 texels (3%), all with n.v < 0.13 and r < 0.36, up to 2.41 (tested: fewer than
//! 600, in that corner, below 2.5). The sampler's `R8G8B8A8_UNORM` target clamps them to 1, and
//! so does a 16-bit linear PNG (`Save(png_format: Linear16)`); the Sample Viewer's load-time
//! table, a float texture where the browser can render to one, keeps them.
//!
//! # Limits and tests
//!
//! - n.v = 1, r = 1: the closed form above, by the estimate (2^16 points) and by an independent
//!   quadrature of `I` (within 1e-4); the quadrature of `E` gives `sqrt(2) / 10`.
//! - The estimate with the sampler's 1024 points agrees with a 2000 x 2000 midpoint quadrature of
//!   `I` within 2e-3 at seven (n.v, r) across the table.
//! - r -> 0: half vectors on the horizon reflect `l` below it unless v is grazing: at r = 1e-3
//!   the texel is exactly 0 from n.v = 0.1 up.
//!
//! One departure: hdrflow's Charlie sampling clamps alpha = r^2 to at least 1e-6
//! (`maths::brdf::specular_lobe`), the sampler's `Charlie()` does not; it matters only for r < 1e-3,
//! rows of a table larger than 500 texels, where the lobe lies on the horizon either way.

use std::f64::consts::PI;

use crate::maths::brdf::specular_lobe::SpecularBrdf;
use glam::DVec3;

/// Ashikhmin's visibility as glTF-IBL-Sampler's `V_Ashikhmin` (Filament's `visibilityAshikhmin`):
/// `clamp(1 / (4 (n.l + n.v - n.l n.v)), 0, 1)`.
#[inline]
pub fn v_ashikhmin(nol: f64, nov: f64) -> f64 {
    let d = 4.0 * (nol + nov - nol * nov);
    if d > 0.0 {
        (1.0 / d).clamp(0.0, 1.0)
    } else {
        1.0 // the shader's clamp of 1 / 0 = +Inf
    }
}

/// One texel of the Charlie LUT: glTF-IBL-Sampler's estimate of `I(n.v, r)` (module doc) with
/// the points `pts` in the sampler's order (`[i / N, radical inverse of i]`: the second drives
/// theta_h, the first phi_h).
pub fn charlie_lut_texel(nov: f64, roughness: f64, pts: &[[f64; 2]]) -> f64 {
    let v = DVec3::new((1.0 - nov * nov).max(0.0).sqrt(), 0.0, nov);
    let mut c = 0.0;
    for &xi in pts {
        // The sampler's `Charlie(xi, roughness)`: alpha = roughness^2, sin(theta) from xi.y.
        let h = SpecularBrdf::Charlie.sample_h([xi[1], xi[0]], roughness * roughness);
        let l = 2.0 * v.dot(h) * h - v;
        let nol = l.z.clamp(0.0, 1.0);
        if nol > 0.0 {
            let noh = h.z.clamp(0.0, 1.0);
            let voh = v.dot(h).clamp(0.0, 1.0);
            // `D_Charlie(roughness, NdotH)`: the perceptual roughness as alpha.
            c += SpecularBrdf::Charlie.d(noh, roughness) * v_ashikhmin(nol, nov) * nol * voh;
        }
    }
    8.0 * PI * c / pts.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::brdf::ggx::{points, LobeSequence};

    /// `D(h; a)` from the formula, apart from the estimator's code.
    fn d(sin_t: f64, a: f64) -> f64 {
        (2.0 + 1.0 / a) * sin_t.powf(1.0 / a) / (2.0 * PI)
    }

    /// By the midpoint rule over (theta_h, phi_h), `n` x `n` cells on the half of the hemisphere
    /// with phi in [0, pi] (both integrands are symmetric about the plane of v), written from the
    /// formulas of the module doc: `I(n.v, r)` and the albedo `E(n.v, r)` of the viewer's lobe.
    fn quadrature(nov: f64, r: f64, n: usize) -> (f64, f64) {
        let (sv, cv) = ((1.0 - nov * nov).sqrt(), nov);
        let (dt, dp) = (0.5 * PI / n as f64, PI / n as f64);
        let (mut i_sum, mut e_sum) = (0.0, 0.0);
        for i in 0..n {
            let t = (i as f64 + 0.5) * dt;
            let (st, ct) = t.sin_cos();
            for j in 0..n {
                let phi = (j as f64 + 0.5) * dp;
                // h = (st cos phi, st sin phi, ct); l = 2 (v.h) h - v; only n.l = l.z is needed.
                let voh = sv * st * phi.cos() + cv * ct;
                let nol = 2.0 * voh * ct - cv;
                if nol <= 0.0 || voh <= 0.0 {
                    continue;
                }
                let va = (1.0 / (4.0 * (nol + nov - nol * nov))).min(1.0);
                let dh = st * dt * dp;
                i_sum += d(st, r) * va * nol * voh * d(st, r * r) * ct * dh;
                e_sum += d(st, r * r) * va * nol * voh * dh;
            }
        }
        (8.0 * PI * 2.0 * i_sum, 4.0 * 2.0 * e_sum)
    }

    /// At n.v = 1 and r = 1: `I = 3 (11 / sqrt 2 - 4) / 70` by the estimate (2^16 points) and
    /// the quadrature, and the albedo of the viewer's lobe is another number, `sqrt(2) / 10`.
    #[test]
    fn the_corner_is_the_closed_form_and_not_the_albedo() {
        let closed = 3.0 * (11.0 / 2f64.sqrt() - 4.0) / 70.0;
        let est = charlie_lut_texel(1.0, 1.0, &points(LobeSequence::Hammersley, 1 << 16));
        let (quad, albedo) = quadrature(1.0, 1.0, 2000);
        assert!((closed - 0.161922).abs() < 1e-6, "{closed}");
        assert!((est - closed).abs() < 1e-4, "estimate {est} vs {closed}");
        assert!((quad - closed).abs() < 1e-4, "quadrature {quad} vs {closed}");
        assert!((albedo - 2f64.sqrt() / 10.0).abs() < 1e-4, "albedo {albedo}");
    }

    /// The sampler's 1024 Hammersley points agree with a 2000 x 2000 quadrature of `I` within
    /// 2e-3 at points across the table (the largest difference, at n.v 0.7, r 0.15, is 1.0e-3).
    #[test]
    fn the_estimate_agrees_with_a_quadrature_of_the_integral() {
        let pts = points(LobeSequence::Hammersley, 1024);
        for (nov, r) in [(0.05, 0.3), (0.2, 0.5), (0.5, 0.5), (0.9, 0.8), (0.3, 1.0), (0.7, 0.15), (1.0, 0.6)] {
            let est = charlie_lut_texel(nov, r, &pts);
            let (quad, _) = quadrature(nov, r, 2000);
            assert!((est - quad).abs() < 2e-3, "n.v {nov}, r {r}: estimate {est}, quadrature {quad}");
        }
    }

    /// As r -> 0 the half vectors lie on the horizon, where `l` is below it unless v is too:
    /// at r = 1e-3 every view from n.v = 0.1 up gets exactly 0.
    #[test]
    fn at_vanishing_roughness_only_grazing_views_see_sheen() {
        let pts = points(LobeSequence::Hammersley, 1024);
        for nov in [0.1, 0.3, 0.6, 1.0] {
            assert_eq!(charlie_lut_texel(nov, 1e-3, &pts), 0.0, "n.v {nov}");
        }
        assert!(charlie_lut_texel(0.002, 1e-3, &pts) > 0.0);
    }
}
