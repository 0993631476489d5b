//! Filtered importance sampling for a group of g x g neighbouring output texels that share one
//! list of reads (issue 36): the sharp levels of a large chain, where a lobe spans many texels
//! of the level it writes and neighbouring texels' lobes nearly coincide.
//!
//! Why: a 4096 chain's level 1 (GGX, alpha 0.0069) is 25 M texels of 1024 filtered reads each,
//! and each read (its face point, level, blocks and 8 texel loads: `maths::ibl::fis_kernel`) is
//! most of the cost. Here the reads are made once per group, in the frame of the group's centre
//! `c` (the direction of the face point at the middle of its texels), and every texel `j` of
//! the group reweights them to its own lobe: with `l_i` drawn from `pdf_c(l) = D(n_c.h) / 4`,
//!
//! `out_j = sum_i L(l_i) W_ij / sum_i W_ij`, `W_ij = D(n_j.h_ij) (n_j.l_i)+ / D(n_c.h_i)`,
//!
//! the self-normalised importance-sampling estimate of the same ratio `prefilter` estimates
//! (Owen, "Monte Carlo theory, methods and examples", 2013, ch. 9.2: consistent, bias O(1/N)).
//! With `n = v`, `(n.h)^2 = (1 + n.l) / 2`, so for GGX (`D = a^2 / (pi (x^2 (a^2 - 1) + 1)^2)`,
//! `x = n.h`) the ratio is `(q_c / q_j)^2` with `q = ((1 - n.l) + a^2 (1 + n.l)) / 2`; `1 - n.l`
//! is taken as `|n - l|^2 / 2` (no cancellation where `n.l` is near 1, as it is in a sharp lobe).
//! `L(l_i)` is the sample's trilinear read at the level the centre's density gives it
//! (Krivanek and Colbert's filter follows the density the samples were drawn from: the
//! centre's). At the group's centre `W = n.l`, the weight of `prefilter`'s own estimate.
//!
//! The group size is chosen by `group_side` so that its texels are close to the centre against
//! the lobe's width (`bench --bake` measures the error per level against `exact: true`, before
//! and after). Deterministic: fixed sample order, sums in a fixed order per lane, no fused
//! multiply-add: the same bits at every instruction-set level (test).

use glam::{DVec3, Vec3};

use super::fis_kernel::{block_rgb, Lobe, PaddedPyramid, BATCH};
use crate::geometry::cubemap as cube;
use crate::maths::brdf::ggx::basis;
use crate::values::Cubemap;

/// The most texels in a group (4 x 4).
pub const MAX_GROUP: usize = 16;

/// A group's texel directions in the frame of its centre (x, y, z lanes) and how many there are.
#[derive(Clone, Copy)]
pub struct GroupNormals {
    pub xyz: [[f32; MAX_GROUP]; 3],
    pub count: usize,
}

impl PaddedPyramid {
    /// The GGX lobe means (`alpha`) of a group's texels `normals`, from one set of reads of
    /// `lobe` drawn around the group's centre (frame `[t, b, n]`); texels past `normals.count`
    /// are zero.
    pub fn group_means(
        &self,
        frame: [Vec3; 3],
        normals: &GroupNormals,
        alpha: f32,
        lobe: &Lobe,
    ) -> [[f32; 3]; MAX_GROUP] {
        group_means_at(crate::cpu::level(), self, frame, normals, alpha * alpha, lobe)
    }

    /// The batched loop: per batch, the reads of `fis_kernel` with unit sample weights summed
    /// into each sample's value (RGB lanes); then, per texel of the group, each sample's weight
    /// `W_ij` over lanes and the weighted sums, in per-lane running sums added in lane order at
    /// the end.
    #[inline(always)]
    fn group_means_lanes(
        &self,
        frame: [Vec3; 3],
        normals: &GroupNormals,
        a2: f32,
        lobe: &Lobe,
    ) -> [[f32; 3]; MAX_GROUP] {
        const ONES: [f32; BATCH] = [1.0; BATCH];
        let count = normals.count.min(MAX_GROUP);
        // per texel: the running R, G, B and weight sums of each lane
        let mut sums = [[[0.0f32; BATCH]; 4]; MAX_GROUP];
        for k in 0..lobe.weight.len() {
            let (reads, list, listed) = self.batch_reads(frame, lobe, k, &ONES);
            let (mut up, mut low) = ([[0.0f32; 8]; BATCH], [[0.0f32; 8]; BATCH]);
            for &r in &list[..listed] {
                let r = r as usize;
                let (w00, w10, w01, w11) = (reads.w00[r], reads.w10[r], reads.w01[r], reads.w11[r]);
                let i = r % BATCH;
                self.accumulate(reads.upper[r], reads.lower[r], [w00, w10], [w01, w11], &mut up[i], &mut low[i]);
            }
            let mut value = [[0.0f32; BATCH]; 3];
            for i in 0..BATCH {
                let rgb = block_rgb(&up[i], &low[i]);
                for c in 0..3 {
                    value[c][i] = rgb[c];
                }
            }
            let (lx, ly, lz, lw) = (&lobe.x[k], &lobe.y[k], &lobe.z[k], &lobe.weight[k]);
            // the centre's q per sample (padding samples, weight 0, get W = 0)
            let mut qc = [0.0f32; BATCH];
            for i in 0..BATCH {
                let d2 = lx[i] * lx[i] + ly[i] * ly[i] + (1.0 - lz[i]) * (1.0 - lz[i]);
                qc[i] = lobe_q(d2, a2);
            }
            for (j, sum) in sums.iter_mut().enumerate().take(count) {
                let (mx, my, mz) = (normals.xyz[0][j], normals.xyz[1][j], normals.xyz[2][j]);
                for i in 0..BATCH {
                    let c = mx * lx[i] + my * ly[i] + mz * lz[i];
                    let (ex, ey, ez) = (mx - lx[i], my - ly[i], mz - lz[i]);
                    let ratio = qc[i] / lobe_q(ex * ex + ey * ey + ez * ez, a2);
                    let w = if c > 0.0 && lw[i] > 0.0 { c * (ratio * ratio) } else { 0.0 };
                    sum[0][i] += w * value[0][i];
                    sum[1][i] += w * value[1][i];
                    sum[2][i] += w * value[2][i];
                    sum[3][i] += w;
                }
            }
        }
        let mut out = [[0.0f32; 3]; MAX_GROUP];
        for (o, sum) in out.iter_mut().zip(&sums).take(count) {
            let total: [f32; 4] = std::array::from_fn(|c| sum[c].iter().fold(0.0f32, |a, &x| a + x));
            if total[3] > 0.0 {
                *o = [total[0] / total[3], total[1] / total[3], total[2] / total[3]];
            }
        }
        out
    }
}

/// `q = ((1 - n.l) + a^2 (1 + n.l)) / 2` from `d2 = |n - l|^2 = 2 (1 - n.l)`: GGX's
/// `(n.h)^2 (a^2 - 1) + 1` at `n = v` (the module doc); `D` is `a^2 / (pi q^2)`.
#[inline(always)]
fn lobe_q(d2: f32, a2: f32) -> f32 {
    let one_minus = 0.5 * d2;
    0.5 * (one_minus + a2 * (2.0 - one_minus))
}

crate::cpu::dispatch! {
    #[levels(Avx512, Avx2)]
    /// [`PaddedPyramid::group_means_lanes`], compiled for AVX-512, for AVX2 and FMA, and for the
    /// baseline: the same bits at every level.
    #[inline]
    fn group_means_at(
        pyramid: &PaddedPyramid,
        frame: [Vec3; 3],
        normals: &GroupNormals,
        a2: f32,
        lobe: &Lobe,
    ) -> [[f32; 3]; MAX_GROUP] = PaddedPyramid::group_means_lanes;
}

/// The group's centre and its texels' directions in the centre's frame: the g x g texels from
/// (x0, y0) of face `face` of a level of face size `size`.
pub fn group_frame(face: usize, x0: usize, y0: usize, g: usize, size: usize) -> ([Vec3; 3], GroupNormals) {
    let mid = |i0: usize| 0.5 * (cube::centre(i0, size) + cube::centre(i0 + g - 1, size));
    let n = cube::face_direction(face, mid(x0), mid(y0));
    let (t, b) = basis(n);
    let mut normals = GroupNormals { xyz: [[0.0; MAX_GROUP]; 3], count: g * g };
    for j in 0..(g * g).min(MAX_GROUP) {
        let d: DVec3 = cube::texel_direction(face, x0 + j % g, y0 + j / g, size);
        normals.xyz[0][j] = d.dot(t) as f32;
        normals.xyz[1][j] = d.dot(b) as f32;
        normals.xyz[2][j] = d.dot(n) as f32;
    }
    ([t.as_vec3(), b.as_vec3(), n.as_vec3()], normals)
}

/// A level of face size `size` filtered with GGX lobes of `alpha` in g x g groups (g divides
/// `size`, g * g at most [`MAX_GROUP`]): rows of groups in parallel.
pub fn grouped_level(pyr: &PaddedPyramid, size: usize, g: usize, alpha: f64, lobe: &Lobe) -> Cubemap {
    use rayon::prelude::*;
    let mut out = Cubemap::new(size);
    out.data.par_chunks_mut(3 * size * g).enumerate().for_each(|(band, texels)| {
        let (face, y0) = (band * g / size, (band * g) % size);
        for x0 in (0..size).step_by(g) {
            let (frame, normals) = group_frame(face, x0, y0, g, size);
            let means = pyr.group_means(frame, &normals, alpha as f32, lobe);
            for (j, m) in means.iter().enumerate().take(g * g) {
                let i = 3 * ((j / g) * size + x0 + j % g);
                texels[i..i + 3].copy_from_slice(m);
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::Level;
    use crate::maths::ibl::fis_kernel::LobeSample;

    fn random_pyramid(size: usize, seed: u64) -> PaddedPyramid {
        let mut rng = crate::maths::sampling::sequences::SplitMix64::new(seed);
        let mut c = Cubemap::new(size);
        for v in c.data.iter_mut() {
            *v = (0.1 + 10.0 * rng.next_f64()) as f32;
        }
        let pyr = crate::maths::ibl::prefilter::pyramid(&c);
        PaddedPyramid::new(&pyr.iter().collect::<Vec<_>>())
    }

    fn ggx_lobe(alpha: f64, top: usize, n: usize) -> Lobe {
        use crate::maths::brdf::ggx::{points, LobeSequence};
        use crate::maths::brdf::specular_lobe::SpecularBrdf;
        let pts = points(LobeSequence::Sobol, n);
        let samples: Vec<LobeSample> =
            crate::maths::ibl::prefilter::lobe_samples(alpha.sqrt(), &pts, SpecularBrdf::Ggx, top, true);
        Lobe::new(&samples)
    }

    /// Every level the processor has gives the portable bits.
    #[test]
    fn every_level_gives_the_portable_bits() {
        let pyr = random_pyramid(16, 7);
        let lobe = ggx_lobe(0.05, 16, 37);
        for (face, x0, y0) in [(0, 0, 0), (2, 6, 2), (5, 14, 14)] {
            let (frame, normals) = group_frame(face, x0, y0, 2, 16);
            let portable = group_means_at(Level::Portable, &pyr, frame, &normals, 0.0025, &lobe);
            for level in crate::cpu::tested_levels() {
                let got = group_means_at(level, &pyr, frame, &normals, 0.0025, &lobe);
                assert_eq!(got.map(|m| m.map(f32::to_bits)), portable.map(|m| m.map(f32::to_bits)), "{level}");
            }
        }
    }

    /// A group of one texel is the per-texel estimate (the same reads and weights; the sums
    /// rounded in another order).
    #[test]
    fn a_group_of_one_is_the_per_texel_estimate() {
        let pyr = random_pyramid(16, 3);
        let lobe = ggx_lobe(0.05, 16, 100);
        for (face, x, y) in [(0, 0, 0), (1, 5, 9), (4, 15, 3)] {
            let (frame, normals) = group_frame(face, x, y, 1, 16);
            let got = pyr.group_means(frame, &normals, 0.05, &lobe)[0];
            let n = cube::texel_direction(face, x, y, 16);
            let (t, b) = basis(n);
            let want = pyr.lobe_mean(n, t, b, &lobe);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() <= 1e-5 * want[c], "{got:?} {want:?}");
            }
        }
    }

    /// A constant map gives the constant at every texel of a group.
    #[test]
    fn a_constant_map_gives_the_constant() {
        let mut c = Cubemap::new(16);
        c.data.iter_mut().for_each(|v| *v = 2.0);
        let pyr = crate::maths::ibl::prefilter::pyramid(&c);
        let padded = PaddedPyramid::new(&pyr.iter().collect::<Vec<_>>());
        let lobe = ggx_lobe(0.02, 16, 64);
        let level = grouped_level(&padded, 8, 4, 0.02, &lobe);
        assert!(level.data.iter().all(|&v| (v - 2.0).abs() < 1e-5));
    }
}
