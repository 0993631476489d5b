//! Exact sums of a zonal filter over a cube map's texels: `sum_t L_t f(n.l_t) Omega_t /
//! sum_t f(n.l_t) Omega_t` over the texels where `f > 0`, for a filter that depends only on the
//! cosine `c = n.l` between the output direction and the texel's. Both exact filters of a bake
//! are zonal: the cosine lobe of irradiance (`f = c`) and the GGX lobe with n = v
//! (`n.h = sqrt((1 + c) / 2)`, so `f = D(sqrt((1 + c) / 2)) c`).
//!
//! Why a kernel of its own: `Texels::weighted_mean` visits texel by texel through a closure of
//! a direction, which the compiler cannot vectorise (and the GGX filter normalises `n + l` per
//! pair). Here the texels are arrays of f64 per component (structure of arrays), each sum
//! runs over [`LANES`] independent accumulators, and the loop is compiled for AVX-512 and for
//! AVX2 and FMA (`crate::cpu::dispatch!`; the same bits at every level, test): the same sums as
//! `weighted_mean` but for the order of the additions (test: to f32 rounding).

use glam::DVec3;

use crate::geometry::cubemap as cube;
use crate::values::Cubemap;

/// Independent accumulators per sum (one AVX-512 register of f64).
const LANES: usize = 8;

/// A cube map's texels as arrays: unit directions, solid angles, and radiance times solid angle.
pub struct ZonalSource {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    omega: Vec<f64>,
    rgb: [Vec<f64>; 3],
}

impl ZonalSource {
    pub fn from_cube(c: &Cubemap) -> ZonalSource {
        let s = c.size;
        let omega_face = cube::face_solid_angles(s);
        let n = c.texel_count().div_ceil(LANES) * LANES;
        let mut src = ZonalSource {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![1.0; n],
            omega: vec![0.0; n],
            rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        };
        for t in 0..c.texel_count() {
            let (f, y, x) = (t / (s * s), (t / s) % s, t % s);
            let d = cube::texel_direction(f, x, y, s);
            let o = omega_face[t % (s * s)];
            (src.x[t], src.y[t], src.z[t], src.omega[t]) = (d.x, d.y, d.z, o);
            for (channel, v) in src.rgb.iter_mut().zip(c.texel(t)) {
                channel[t] = v as f64 * o;
            }
        }
        src
    }

    /// The filter `f(c)` (zero or negative: the texel is left out) averaged around unit `n`, at
    /// [`crate::cpu::level`] (`mean_at`).
    #[inline]
    pub fn mean(&self, n: DVec3, f: impl Fn(f64) -> f64 + Copy) -> [f32; 3] {
        mean_at(crate::cpu::level(), self, n, f)
    }

    #[inline(always)]
    fn mean_lanes(&self, n: DVec3, f: impl Fn(f64) -> f64 + Copy) -> [f32; 3] {
        let mut acc = [[0.0f64; LANES]; 3];
        let mut total = [0.0f64; LANES];
        let chunks = self.x.chunks_exact(LANES).zip(self.y.chunks_exact(LANES)).zip(self.z.chunks_exact(LANES));
        let rest = self.omega.chunks_exact(LANES).zip(self.rgb[0].chunks_exact(LANES));
        let rest = rest.zip(self.rgb[1].chunks_exact(LANES)).zip(self.rgb[2].chunks_exact(LANES));
        for (((x, y), z), (((o, r), g), b)) in chunks.zip(rest) {
            for i in 0..LANES {
                let c = n.x * x[i] + n.y * y[i] + n.z * z[i];
                let w = f(c).max(0.0);
                total[i] += w * o[i];
                acc[0][i] += w * r[i];
                acc[1][i] += w * g[i];
                acc[2][i] += w * b[i];
            }
        }
        let weight: f64 = total.iter().sum();
        if weight > 0.0 {
            acc.map(|a| (a.iter().sum::<f64>() / weight) as f32)
        } else {
            [0.0; 3]
        }
    }
}

crate::cpu::dispatch! {
    #[levels(Avx512, Avx2)]
    /// [`ZonalSource::mean_lanes`] of `source`, compiled for AVX-512, for AVX2 and FMA, and for the
    /// baseline: the same bits at every level.
    #[inline]
    fn mean_at(source: &ZonalSource, n: DVec3, f: impl Fn(f64) -> f64 + Copy) -> [f32; 3] =
        ZonalSource::mean_lanes;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::Level;
    use crate::maths::ibl::irradiance_cube::Texels;

    #[test]
    fn matches_the_texel_by_texel_sum() {
        let mut c = Cubemap::new(6);
        let mut state = 7u64;
        for v in c.data.iter_mut() {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            *v = ((state >> 40) as f32 / (1u64 << 24) as f32) * 5.0;
        }
        let zonal = ZonalSource::from_cube(&c);
        let texels = Texels::from_cube(&c);
        for n in [DVec3::X, DVec3::new(0.3, -0.5, 0.8).normalize(), DVec3::new(-1.0, 1.0, 1.0).normalize()] {
            let want = texels.weighted_mean(|l| n.dot(l));
            let got = zonal.mean(n, |c| c);
            for k in 0..3 {
                assert!(((got[k] - want[k]) / want[k]).abs() < 1e-6, "{n}: {got:?} vs {want:?}");
            }
        }
    }

    /// Every level the processor has gives the portable bits, for both filters of a bake (the
    /// cosine, and a GGX-like lobe with a square root and a division).
    #[test]
    fn every_level_gives_the_portable_bits() {
        let levels = crate::cpu::tested_levels();
        let mut c = Cubemap::new(5);
        let mut state = 11u64;
        for v in c.data.iter_mut() {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            *v = ((state >> 40) as f32 / (1u64 << 24) as f32) * 5.0;
        }
        let zonal = ZonalSource::from_cube(&c);
        let lobe = |c: f64| {
            let nh = ((1.0 + c) / 2.0).max(0.0).sqrt();
            let d = nh * nh * (0.09 - 1.0) + 1.0;
            0.09 / (d * d) * c
        };
        for n in [DVec3::Y, DVec3::new(0.3, -0.5, 0.8).normalize(), DVec3::new(-1.0, 1.0, 1.0).normalize()] {
            let (cosine, ggx) = (mean_at(Level::Portable, &zonal, n, |c| c), mean_at(Level::Portable, &zonal, n, lobe));
            for &level in &levels {
                assert_eq!(mean_at(level, &zonal, n, |c| c).map(f32::to_bits), cosine.map(f32::to_bits), "{level}");
                assert_eq!(mean_at(level, &zonal, n, lobe).map(f32::to_bits), ggx.map(f32::to_bits), "{level}");
            }
        }
    }
}
