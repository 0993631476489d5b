//! Filament's irradiance spherical harmonics: the 9 coefficients `cmgen --sh-shader` (and
//! `--deploy`) writes to `sh.txt` and the KTX key `sh`, which Filament's shader evaluates as
//!
//! ```text
//! E(n) / pi = sh[0] + sh[1] y + sh[2] z + sh[3] x + sh[4] y x + sh[5] y z
//!           + sh[6] (3 z^2 - 1) + sh[7] z x + sh[8] (x^2 - y^2)
//! ```
//!
//! (`Irradiance_SphericalHarmonics`, shaders/src/surface_light_indirect.fs, `n` the world
//! normal; `max(.., 0)` after). So `sh[i] = (A_l / pi) k_i^2 sum L(d) P_i(d) dOmega`, where
//! `P_i` is the polynomial above, `k_i` the constant that makes `k_i P_i` orthonormal and `A_l`
//! the clamped-cosine band factor (`maths::ibl::sh::lambert_coefficient`): cmgen computes
//! `computeSH(irradiance = true)` (`K_i A_l sum L Y'_i`, its basis with the Condon-Shortley
//! phase), then `preprocessSHForShader` multiplies by the signed `K_i / pi`; the phase appears
//! twice and cancels (libs/ibl/src/CubemapSH.cpp). With hdrflow's orthonormal `L_i = k_i sum L
//! P_i dOmega` (no phase, `maths::ibl::sh`) this is `sh[i] = (A_l / pi) k_i L_i`. A constant radiance
//! of 1 gives `sh = (1, 0, ..., 0)`: the same `E / pi` as `IrradianceCubemap` (tested, with a
//! linear map's closed form `E / pi = 1 + (2/3) n.y` for `L = 1 + d.y`).
//!
//! cmgen also windows the coefficients by default (`--sh-window=auto`, a sinc^4 window with the
//! cut-off found by bisection so the result is non-negative); this module does not: window in
//! `IrradianceCubemap` or leave the clamp to Filament's `max(.., 0)`.

use std::f64::consts::PI;

use crate::maths::ibl::sh::{lambert_coefficient, sh_lm};

/// The orthonormal constants `k_i` of `Y_i = k_i P_i` for the 9 order-2 functions, in
/// `l (l + 1) + m` order: `1 / (2 sqrt(pi))`, `sqrt(3) / (2 sqrt(pi))` (x3),
/// `sqrt(15) / (2 sqrt(pi))`, `sqrt(15) / (2 sqrt(pi))`, `sqrt(5) / (4 sqrt(pi))`,
/// `sqrt(15) / (2 sqrt(pi))`, `sqrt(15) / (4 sqrt(pi))` (Sloan 2008; cmgen's `A[]`, unsigned).
pub fn basis_constants() -> [f64; 9] {
    let s = PI.sqrt();
    let (k1, k2) = (3f64.sqrt() / (2.0 * s), 15f64.sqrt() / (2.0 * s));
    [1.0 / (2.0 * s), k1, k1, k1, k2, k2, 5f64.sqrt() / (4.0 * s), k2, 15f64.sqrt() / (4.0 * s)]
}

/// Filament's pre-scaled coefficients from hdrflow's orthonormal `L_lm` (index `l (l + 1) + m`,
/// frame `World` for Filament's world): `sh[i] = (A_l / pi) k_i L_i`. Coefficients past the
/// given order are 0.
pub fn prescaled(coeffs: &[[f64; 3]]) -> [[f64; 3]; 9] {
    let k = basis_constants();
    let mut out = [[0.0; 3]; 9];
    for (i, c) in coeffs.iter().take(9).enumerate() {
        let (l, _) = sh_lm(i);
        let s = lambert_coefficient(l) / PI * k[i];
        out[i] = c.map(|v| v * s);
    }
    out
}

/// `E(n) / pi` from Filament's coefficients, as Filament's shader evaluates them (before its
/// clamp to 0), `n = (x, y, z)` a unit world normal.
pub fn evaluate(sh: &[[f64; 3]; 9], n: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = n;
    let p = [1.0, y, z, x, y * x, y * z, 3.0 * z * z - 1.0, z * x, x * x - y * y];
    let mut out = [0.0; 3];
    for (c, w) in sh.iter().zip(p) {
        for k in 0..3 {
            out[k] += c[k] * w;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;
    use crate::maths::ibl::sh::project;
    use crate::values::{Image, ShFrame};

    fn map(f: impl Fn([f64; 3]) -> f64) -> Image {
        let (w, h) = (256, 128);
        Image::from_fn_rgb(w, h, |x, y| [f(latlong::texel_direction(x, y, w, h)) as f32; 3])
    }

    #[test]
    fn constant_radiance_gives_one_and_a_linear_map_its_closed_form() {
        let sh = prescaled(&project(&map(|_| 1.0), 2, ShFrame::World));
        assert!((sh[0][0] - 1.0).abs() < 1e-4, "{:?}", sh[0]);
        assert!(sh[1..].iter().all(|c| c[0].abs() < 1e-4), "{sh:?}");
        // L = 1 + d.y: E / pi = 1 + (2/3) n.y exactly (bands 0 and 1 only).
        let sh = prescaled(&project(&map(|d| 1.0 + d[1]), 2, ShFrame::World));
        for n in [[0.0, 1.0, 0.0], [0.6, 0.0, -0.8], [0.0, -1.0, 0.0]] {
            let e = evaluate(&sh, n)[0];
            assert!((e - (1.0 + 2.0 / 3.0 * n[1])).abs() < 1e-3, "{n:?}: {e}");
        }
    }

    /// cmgen's old `computeIrradianceSH3Bands` summed the texels straight into the pre-scaled
    /// form, `sh[i] = sum L P_i dOmega * A_i`, `A_i = c_l / (4 pi^2) * (1, 3, 3, 3, 15, 15, 5/4,
    /// 15, 15/4)`, `c_l` = pi, 2 pi / 3, pi / 4: the same numbers.
    #[test]
    fn matches_cmgens_direct_prescaled_sum() {
        let img = map(|d| 2.0 + d[0] - 0.5 * d[2] + d[1] * d[2] + 0.3 * d[0] * d[0]);
        let sh = prescaled(&project(&img, 2, ShFrame::World));
        let c = [PI, 2.0 * PI / 3.0, PI / 4.0];
        let f = [1.0, 3.0, 3.0, 3.0, 15.0, 15.0, 1.25, 15.0, 3.75];
        let band = [0, 1, 1, 1, 2, 2, 2, 2, 2];
        let mut direct = [0.0f64; 9];
        let (w, h) = (img.width, img.height);
        for y in 0..h {
            for x in 0..w {
                let [dx, dy, dz] = latlong::texel_direction(x, y, w, h);
                let p = [1.0, dy, dz, dx, dy * dx, dy * dz, 3.0 * dz * dz - 1.0, dz * dx, dx * dx - dy * dy];
                let l = img.rgb(x, y)[0] as f64 * latlong::texel_solid_angle(y, w, h);
                for i in 0..9 {
                    direct[i] += l * p[i] * c[band[i]] / (4.0 * PI * PI) * f[i];
                }
            }
        }
        for i in 0..9 {
            assert!((sh[i][0] - direct[i]).abs() < 1e-9, "{i}: {} vs {}", sh[i][0], direct[i]);
        }
    }
}
