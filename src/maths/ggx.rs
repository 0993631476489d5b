//! The GGX (Trowbridge-Reitz) microfacet lobe for image-based lighting: its normal distribution,
//! importance sampling, Smith height-correlated visibility, the split-sum DFG texture, and
//! specular prefiltering of a cube map (filtered importance sampling and an exact reference).
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
//! - Prefiltering with `n = v = r` (Karis 2013): `out(n) = int L(l) D(h) (n.l)+ dl /
//!   int D(h) (n.l)+ dl`, the lobe weighted by `n.l` as Filament and Karis do, never clamped.
//!   Estimated with `l` drawn from `pdf(l) = D(h) / 4` (n = v makes `n.h = v.h`) as
//!   `sum L(l_i) (n.l_i) / sum (n.l_i)`, where `L(l_i)` is read from the source's mip pyramid at
//!   level `lod = 0.5 log2(Omega_s / Omega_p) + 1`, `Omega_s = 1 / (N pdf)`, `Omega_p` the solid
//!   angle of a level-0 texel in direction `l_i`, `(4 / S^2) / (1 + a^2 + b^2)^(3/2)` at face point
//!   (a, b) (filtered importance sampling: J. Krivanek, M. Colbert, "Real-time Shading with Filtered
//!   Importance Sampling", EGSR 2008, eq. 4 with their bias of 1; GPU Gems 3 ch. 20; Filament and
//!   the glTF sampler use the mean texel solid angle instead, which blurs a face's corners less
//!   than its centre). The exact
//!   reference evaluates the same ratio with every source texel as `l`, weighted by its exact
//!   solid angle, with the lobe evaluated at the texel's centre: a quadrature that is accurate
//!   while the lobe spans several source texels (alpha of a few texel angles). A constant
//!   environment gives 1 in both to rounding (white furnace, tested); on the smooth built-in
//!   `linear` map the two agree within 0.9% at every texel of every level (16 cube, 1024 samples;
//!   tested to 1.5%).

use std::f64::consts::PI;

use glam::DVec3;

use crate::geometry::cubemap as cube;
use crate::maths::fis_kernel::{Lobe, LobeSample, PaddedPyramid};
use crate::maths::resample::downsample;
use crate::maths::sequences::{radical_inverse, sobol_2d};
use crate::maths::specular_lobe::SpecularBrdf;
use crate::maths::zonal_sum::ZonalSource;
use crate::values::{Cubemap, MipChain};

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

/// The source's mip pyramid, down to 1 x 1 faces (each level the solid-angle-weighted 2 x 2 mean).
pub fn pyramid(src: &Cubemap) -> Vec<Cubemap> {
    std::iter::once(src.clone()).chain(pyramid_below(src)).collect()
}

/// [`pyramid`] without its level 0 (the source itself, which a 4096 cube makes 1.2 GB: the
/// chain borrows it instead of copying it).
pub fn pyramid_below(src: &Cubemap) -> Vec<Cubemap> {
    let mut below: Vec<Cubemap> = Vec::new();
    while below.last().unwrap_or(src).size > 1 {
        let next = downsample(below.last().unwrap_or(src));
        below.push(next);
    }
    below
}

/// Perceptual roughness of level k of `levels`: k / (levels - 1) (0 for a single level).
pub fn level_roughness(k: usize, levels: usize) -> f64 {
    if levels <= 1 {
        0.0
    } else {
        k as f64 / (levels - 1) as f64
    }
}

/// The lobe of one filtered level in the frame n = v = +z, for a pyramid whose level 0 has faces
/// of `top` texels: each sample's light direction, its cosine and its pyramid level (Colbert and
/// Krivanek's `0.5 log2(omega_s / omega_p) + 1`, `omega_s = 1 / (N pdf)`, `omega_p` a face-centre
/// texel of level 0; the per-texel offset is the kernel's). `filtered: false` reads level 0.
pub fn lobe_samples(
    roughness: f64,
    pts: &[[f64; 2]],
    brdf: SpecularBrdf,
    top: usize,
    filtered: bool,
) -> Vec<LobeSample> {
    let alpha = roughness * roughness;
    let s0 = top as f64;
    // The solid angle of a texel at a face's centre (texels elsewhere: `maths::fis_kernel`).
    let omega_p = 4.0 / (s0 * s0);
    let n = pts.len() as f64;
    pts.iter()
        .filter_map(|&u| {
            let h = brdf.sample_h(u, alpha);
            let l = 2.0 * h.z * h - DVec3::Z;
            if l.z <= 0.0 {
                return None;
            }
            let pdf = brdf.d(h.z, alpha) / 4.0;
            let omega_s = 1.0 / (n * pdf);
            let lod = 0.5 * (omega_s / omega_p).log2() + 1.0;
            // A zero pdf (Charlie's lobe at h = n) reads the coarsest level; -inf the finest.
            // Plain sampling: far enough below 0 that the corner offset (at most 1.19) stays below.
            let lod = if !filtered {
                -16.0
            } else if lod.is_nan() {
                0.0
            } else {
                lod
            };
            Some(LobeSample { l: l.as_vec3(), weight: l.z as f32, lod: lod as f32 })
        })
        .collect()
}

/// One level filtered with filtered importance sampling, for the lobe `brdf`
/// (`maths::specular_lobe`); `filtered: false` reads every sample from level 0 (plain Monte
/// Carlo with bilinear reads: the estimate the benchmark compares against).
pub fn prefilter_level_fis(
    pyr: &PaddedPyramid,
    size: usize,
    roughness: f64,
    pts: &[[f64; 2]],
    brdf: SpecularBrdf,
    filtered: bool,
) -> Cubemap {
    let mut lobe = lobe_samples(roughness, pts, brdf, pyr.top_size(), filtered);
    // In order of level, so that the reads of one level and of two levels each come in runs (the
    // kernel's per-sample branch is then predicted); the sum's order is fixed either way.
    lobe.sort_by(|a, b| a.lod.total_cmp(&b.lod));
    let lobe = Lobe::new(&lobe);
    Cubemap::from_fn(size, |f, x, y| {
        let nrm = cube::texel_direction(f, x, y, size);
        let (t, b) = basis(nrm);
        pyr.lobe_mean(nrm, t, b, &lobe)
    })
}

/// One level filtered exactly: the same weighted lobe summed over every source texel.
pub fn prefilter_level_exact(src: &Cubemap, size: usize, roughness: f64, brdf: SpecularBrdf) -> Cubemap {
    let texels = ZonalSource::from_cube(src);
    let lobe = zonal_lobe(brdf, roughness * roughness);
    Cubemap::from_fn(size, |f, x, y| texels.mean(cube::texel_direction(f, x, y, size), lobe))
}

/// The prefilter's weight `D(h) (n.l)+` as a function of `c = n.l` alone (n = v, so h =
/// normalize(n + l) and `n.h = sqrt((1 + c) / 2)`): the filter `ZonalSource::mean` sums.
pub fn zonal_lobe(brdf: SpecularBrdf, alpha: f64) -> impl Fn(f64) -> f64 + Copy {
    move |c: f64| if c > 0.0 { brdf.d((0.5 * (1.0 + c)).sqrt(), alpha) * c } else { 0.0 }
}

/// The most texel pairs (output texels times source texels) a level is summed exactly over
/// instead of sampled: 2^26, about a tenth of a second on two cores.
pub const ROUGH_EXACT_PAIRS: usize = 1 << 26;

/// The pyramid level a GGX level of face size `size` and perceptual roughness `roughness` is
/// summed exactly over, when that is cheap: the coarsest level whose face-centre texel (2 / s
/// radians) is at most alpha / 8, if it has at most [`ROUGH_EXACT_PAIRS`] pairs with the level.
/// Where the lobe spans 8 texels or more, the exact sum's quadrature (the lobe at each texel's
/// centre) is within about 1e-3 of the sum over the finest level (`prefilter_level_exact`'s
/// error bound; `bench --bake` measures it), and needs no samples.
pub fn exact_source_level(level_sizes: &[usize], size: usize, roughness: f64) -> Option<usize> {
    let alpha = roughness * roughness;
    let m = level_sizes.iter().rposition(|&s| 2.0 / s as f64 <= alpha / 8.0)?;
    let pairs = 36 * (size * size).saturating_mul(level_sizes[m] * level_sizes[m]);
    (pairs <= ROUGH_EXACT_PAIRS).then_some(m)
}

/// The prefiltered chain of `src` (level 0 is `src` itself): `levels` levels, level k of size
/// max(1, S >> k) and roughness k / (levels - 1), GGX.
pub fn prefilter(src: &Cubemap, levels: usize, samples: usize, seq: LobeSequence, exact: bool) -> MipChain {
    let roughness: Vec<f64> = (0..levels).map(|k| level_roughness(k, levels)).collect();
    prefilter_chain(src, &roughness, samples, seq, exact, SpecularBrdf::Ggx, false)
}

/// The chain of `src` filtered with `brdf`, one level per entry of `roughness` (perceptual),
/// level k of size max(1, S >> k). A GGX level of roughness 0 is the source itself at that size
/// (`src` at level 0, its solid-angle-weighted pyramid below); Charlie levels are always
/// filtered (its lobe at roughness 0 is a grazing one, not a mirror).
pub fn prefilter_chain(
    src: &Cubemap,
    roughness: &[f64],
    samples: usize,
    seq: LobeSequence,
    exact: bool,
    brdf: SpecularBrdf,
    rough_exact: bool,
) -> MipChain {
    let pts = points(seq, samples);
    let mirror_below_top = brdf == SpecularBrdf::Ggx && roughness.iter().skip(1).any(|&r| r == 0.0);
    let below = if exact && !mirror_below_top { Vec::new() } else { pyramid_below(src) };
    let pyr: Vec<&Cubemap> = std::iter::once(src).chain(&below).collect();
    let level_sizes: Vec<usize> = pyr.iter().map(|c| c.size).collect();
    // How each level is made: a copy of the source at its size (GGX at roughness 0), exact over
    // a pyramid level, or filtered importance sampling.
    enum How {
        Copy,
        Exact(usize),
        Fis,
    }
    let how: Vec<How> = roughness
        .iter()
        .enumerate()
        .map(|(k, &rough)| {
            let size = (src.size >> k).max(1);
            if brdf == SpecularBrdf::Ggx && rough == 0.0 {
                How::Copy
            } else if exact {
                How::Exact(0)
            } else if let Some(m) = (rough_exact && brdf == SpecularBrdf::Ggx)
                .then(|| exact_source_level(&level_sizes, size, rough))
                .flatten()
            {
                How::Exact(m)
            } else {
                How::Fis
            }
        })
        .collect();
    // The padded pyramid starts at the finest level a filtered level's sample reads (each read is
    // at its sample's level or coarser): a 4096 chain's sharpest filtered level reads the 2048
    // level at the finest, its Charlie chain the 128 one, so the 1.6 GB padded copy of the top is
    // not made. The lods are then counted from that level: the same reads.
    let finest_read = roughness
        .iter()
        .zip(&how)
        .filter(|(_, h)| matches!(h, How::Fis))
        .flat_map(|(&r, _)| lobe_samples(r, &pts, brdf, src.size, true))
        .map(|s| s.lod.max(0.0).floor() as usize)
        .min()
        .unwrap_or(0)
        .min(pyr.len() - 1);
    let mut padded = None;
    // The filtered levels first, the copies of the source once the padded pyramid is gone: for a
    // 4096 cube the copy of level 0 (1.2 GB) and the padded pyramid are never held at once.
    let mut levels: Vec<Option<Cubemap>> = how
        .iter()
        .zip(roughness)
        .enumerate()
        .map(|(k, (h, &rough))| {
            let size = (src.size >> k).max(1);
            match *h {
                How::Copy => None,
                How::Exact(m) => Some(prefilter_level_exact(pyr[m], size, rough, brdf)),
                How::Fis => {
                    let padded = padded.get_or_insert_with(|| PaddedPyramid::new(&pyr[finest_read..]));
                    Some(prefilter_level_fis(padded, size, rough, &pts, brdf, true))
                }
            }
        })
        .collect();
    drop(padded);
    for (k, level) in levels.iter_mut().enumerate() {
        if level.is_none() {
            *level = Some(pyr[k.min(pyr.len() - 1)].clone());
        }
    }
    MipChain {
        levels: levels.into_iter().map(|l| l.expect("every level is filled")).collect(),
        roughness: roughness.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::builtin::builtin;
    use crate::maths::resample::{to_cube, LatLongSource};

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
    fn white_furnace_fis_and_exact() {
        let env = builtin("constant").unwrap();
        let c = to_cube(&LatLongSource::new(&env), 8);
        for exact in [false, true] {
            let chain = prefilter(&c, 4, 64, LobeSequence::Sobol, exact);
            assert_eq!(chain.levels.iter().map(|l| l.size).collect::<Vec<_>>(), vec![8, 4, 2, 1]);
            for l in &chain.levels {
                assert!(l.data.iter().all(|&v| (v - 1.0).abs() < 1e-3), "exact {exact}");
            }
        }
    }

    /// On a smooth map the filtered estimate and the exact sum agree closely at every level.
    #[test]
    fn fis_matches_exact_on_a_smooth_map() {
        let env = builtin("linear").unwrap();
        let c = to_cube(&LatLongSource::new(&env), 16);
        let fis = prefilter(&c, 4, 1024, LobeSequence::Sobol, false);
        let ex = prefilter(&c, 4, 1, LobeSequence::Sobol, true);
        for (k, (a, b)) in fis.levels.iter().zip(&ex.levels).enumerate() {
            let worst = a.data.iter().zip(&b.data).fold(0.0f64, |m, (x, y)| m.max((x - y).abs() as f64 / *y as f64));
            // Measured: 0, 0.0049, 0.0043, 0.0090 (levels 0-3).
            assert!(worst < 1.5e-2, "level {k}: {worst}");
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [DVec3::X, DVec3::Y, -DVec3::Z, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let (t, b) = basis(n);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(n).abs() < 1e-12 && (t.cross(b) - n).length() < 1e-12);
        }
    }
}
