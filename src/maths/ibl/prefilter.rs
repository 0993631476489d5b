//! Specular prefiltering of a cube map with a GGX (or Charlie) lobe: filtered importance sampling
//! and an exact reference, for the chains engines read by roughness. The lobe itself is
//! [`crate::maths::brdf::ggx`]; roughness is perceptual, `alpha = roughness^2`.
//!
//! Prefiltering with `n = v = r` (Karis 2013): `out(n) = int L(l) D(h) (n.l)+ dl /
//! int D(h) (n.l)+ dl`, the lobe weighted by `n.l` as Filament and Karis do, never clamped.
//! Estimated with `l` drawn from `pdf(l) = D(h) / 4` (n = v makes `n.h = v.h`) as
//! `sum L(l_i) (n.l_i) / sum (n.l_i)`, where `L(l_i)` is read from the source's mip pyramid at
//! level `lod = 0.5 log2(Omega_s / Omega_p) + 1`, `Omega_s = 1 / (N pdf)`, `Omega_p` the solid
//! angle of a level-0 texel in direction `l_i`, `(4 / S^2) / (1 + a^2 + b^2)^(3/2)` at face point
//! (a, b) (filtered importance sampling: J. Krivanek, M. Colbert, "Real-time Shading with Filtered
//! Importance Sampling", EGSR 2008, eq. 4 with their bias of 1; GPU Gems 3 ch. 20; Filament and
//! the glTF sampler use the mean texel solid angle instead, which blurs a face's corners less
//! than its centre). The exact
//! reference evaluates the same ratio with every source texel as `l`, weighted by its exact
//! solid angle, with the lobe evaluated at the texel's centre: a quadrature that is accurate
//! while the lobe spans several source texels (alpha of a few texel angles). A constant
//! environment gives 1 in both to rounding (white furnace, tested); on the smooth built-in
//! `linear` map the two agree within 0.9% at every texel of every level (16 cube, 1024 samples;
//! tested to 1.5%).

use glam::DVec3;

use crate::geometry::cubemap as cube;
use crate::maths::brdf::ggx::{basis, points, LobeSequence};
use crate::maths::brdf::specular_lobe::SpecularBrdf;
use crate::maths::ibl::fis_group::{grouped_level, MAX_GROUP};
use crate::maths::ibl::fis_kernel::{Lobe, LobeSample, PaddedPyramid};
use crate::maths::ibl::zonal_sum::ZonalSource;
use crate::maths::resample::layouts::downsample;
use crate::values::{Cubemap, MipChain};

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
    // The solid angle of a texel at a face's centre (texels elsewhere: `maths::ibl::fis_kernel`).
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
/// (`maths::brdf::specular_lobe`); `filtered: false` reads every sample from level 0 (plain Monte
/// Carlo with bilinear reads: the estimate the benchmark compares against). `group` > 1
/// (GGX only; it divides `size`, and `group^2` is at most `fis_group::MAX_GROUP`): each `group`
/// x `group` block of texels shares one set of reads (`maths::ibl::fis_group`; [`group_side`]
/// chooses it); 1 otherwise.
pub fn prefilter_level_fis(
    pyr: &PaddedPyramid,
    size: usize,
    roughness: f64,
    pts: &[[f64; 2]],
    brdf: SpecularBrdf,
    filtered: bool,
    group: usize,
) -> Cubemap {
    let mut lobe = lobe_samples(roughness, pts, brdf, pyr.top_size(), filtered);
    // In order of level, so that the reads of one level and of two levels each come in runs (the
    // kernel's per-sample branch is then predicted); the sum's order is fixed either way.
    lobe.sort_by(|a, b| a.lod.total_cmp(&b.lod));
    let lobe = Lobe::new(&lobe);
    if group > 1 && brdf == SpecularBrdf::Ggx && size.is_multiple_of(group) && group * group <= MAX_GROUP {
        return grouped_level(pyr, size, group, roughness * roughness, &lobe);
    }
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

/// How wide a group may be against the lobe's alpha: a group of side g is used where its width
/// at a face's centre, `g (2 / size)` radians, times this is at most alpha (0.8 alpha). Groups
/// 0.5-0.8 alpha wide kept the error of every level of the 4096 Khronos chain's ratios (`bench
/// --bake --bake-khronos-ratios`), and a group 4 alpha wide (a Bevy 256 chain's level 1 in 4 x 4
/// groups) moved it by 4%; a group of a whole 4 x 4 face at alpha 0.56 is eight times worse.
pub const GROUP_TEXELS_PER_ALPHA: f64 = 1.25;

/// The side of the texel groups that share one set of reads (`maths::ibl::fis_group`) for a
/// GGX level of face size `size` and perceptual roughness `roughness`: the largest of 4 and 2
/// that divides `size` and whose group is narrow against the lobe ([`GROUP_TEXELS_PER_ALPHA`]),
/// else 1 (every texel its own reads). Sharp levels of large chains: a 4096 chain's levels 1-7
/// in groups of 4; a Bevy 256 chain keeps 1 (level 1: alpha 0.016 and 128 texels, as wide).
pub fn group_side(size: usize, roughness: f64, brdf: SpecularBrdf) -> usize {
    let alpha = roughness * roughness;
    let texel = 2.0 / size as f64;
    [4, 2]
        .into_iter()
        .find(|&g| {
            brdf == SpecularBrdf::Ggx && size.is_multiple_of(g) && g as f64 * texel * GROUP_TEXELS_PER_ALPHA <= alpha
        })
        .unwrap_or(1)
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
                    let group = group_side(size, rough, brdf);
                    Some(prefilter_level_fis(padded, size, rough, &pts, brdf, true, group))
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
    use crate::maths::resample::layouts::{to_cube, LatLongSource};

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

    /// The groups' rule: the sharp levels of a 4096 chain (Khronos, 13 levels) in groups of 4,
    /// a Bevy 256 chain's level 1 (texels as wide as alpha) per texel, Charlie never grouped.
    #[test]
    fn group_sides() {
        let khronos: Vec<usize> =
            (1..8).map(|k| group_side(4096 >> k, level_roughness(k, 13), SpecularBrdf::Ggx)).collect();
        assert_eq!(khronos, vec![4; 7]);
        let bevy: Vec<usize> = (1..4).map(|k| group_side(256 >> k, level_roughness(k, 9), SpecularBrdf::Ggx)).collect();
        assert_eq!(bevy, vec![1; 3]);
        assert_eq!(group_side(2048, 0.5, SpecularBrdf::Charlie), 1);
        assert_eq!(group_side(6, 1.0, SpecularBrdf::Ggx), 2);
    }

    /// Grouped and per-texel estimates of a sharp level agree with the exact sum alike on a
    /// smooth map (measured: worst 1.89e-2, 1.90e-2 and 1.91e-2 for groups of 1, 2 and 4: the
    /// filter's blur of a 64 source, not the groups).
    #[test]
    fn grouped_levels_match_exact_on_a_smooth_map() {
        let env = builtin("linear").unwrap();
        let c = to_cube(&LatLongSource::new(&env), 64);
        let pyr = pyramid(&c);
        let padded = PaddedPyramid::new(&pyr.iter().collect::<Vec<_>>());
        let pts = points(LobeSequence::Sobol, 256);
        let (size, rough) = (32, 0.6);
        assert_eq!(group_side(size, rough, SpecularBrdf::Ggx), 4);
        let ex = prefilter_level_exact(&c, size, rough, SpecularBrdf::Ggx);
        for group in [1, 2, 4] {
            let got = prefilter_level_fis(&padded, size, rough, &pts, SpecularBrdf::Ggx, true, group);
            let worst = got.data.iter().zip(&ex.data).fold(0.0f64, |m, (x, y)| m.max((x - y).abs() as f64 / *y as f64));
            eprintln!("groups of {group}: worst relative difference {worst:.2e}");
            assert!(worst < 2.5e-2, "groups of {group}: {worst}");
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
}
