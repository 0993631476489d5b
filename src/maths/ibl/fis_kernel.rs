//! The inner loop of filtered importance sampling (`maths::ibl::prefilter::prefilter_level_fis`): trilinear
//! reads of a cube map's mip pyramid, in f32, from faces that carry a one-texel border.
//!
//! Why a kernel of its own: a prefiltered chain is 10^8 such reads (a 256 chain, 1024 samples
//! per texel), and the f64 lookup that resolves every edge texel through a direction (seamless
//! bilinear filtering) spends most of its time on bounds checks, the neighbour face's lookup and
//! a `log2` per read. Here each face of each level is stored with a border ring copied once from
//! the texels the f64 lookup reads beyond its edges (the texel containing the direction of the
//! neighbour's centre in the face's plane, `geometry::cubemap`), so a bilinear read needs no
//! branch and reads the same texels as before; the per-read level offset
//! `0.75 log2(1 + a^2 + b^2)` (the texel's solid angle against a face-centre one) uses a cubic
//! for `log2` on [1, 3] (error below 1.5e-3, test). The result matches the f64 lookup within
//! 4e-3 relative on a random map, at every level (test; measured 1.9e-3, the cubic's shift of
//! the level between two levels' reads).
//!
//! How the loop is laid out (issue 36: on AVX2 without AVX-512 the per-read scalar work, not
//! the memory, was most of the time): 16 samples a batch; their face points, levels, 2 x 2
//! blocks and bilinear weights are computed as arithmetic over arrays of u32 and f32 lanes
//! (vectorised; the per-level tables read into arrays first); each sample has a read at its
//! level with weight `w (1 - t)` and, when between two levels, one at the next with `w t`, listed
//! without a branch (whether a sample is between two levels is random at the middle levels);
//! a listed read is two 8-float loads (a block row's two RGBA texels, adjacent), weighted and
//! added to running sums of each row, with no branch. The same bits at every instruction-set
//! level (test): no fused multiply-add, sums in a fixed order.

use glam::{DVec3, Vec3};

use crate::geometry::cubemap as cube;
use crate::values::Cubemap;

/// The most levels a padded pyramid holds (a face of 2^31 texels would not fit in memory): the
/// per-level tables are fixed arrays indexed by a masked level, without a bounds check, so that
/// the lane loops vectorise.
const MAX_LEVELS: usize = 32;

/// A pyramid (level 0 the finest) whose faces carry a one-texel border ring: six faces of
/// `(size + 2)^2` texels per level, row by row, every level one after the other in one flat
/// RGBA array (RGB and a zero: a texel and its right neighbour are one 8-float load). Texels are
/// indexed in `u32` (the lane loops' width): at most 2^32 - 1 of them, a 16k face's pyramid.
pub struct PaddedPyramid {
    rgba: Vec<f32>,
    levels: usize,
    /// per level: its first texel in `rgba` (in texels), its face size, as f32 and as an
    /// integer, and its padded stride
    offsets: [u32; MAX_LEVELS],
    sizes: [f32; MAX_LEVELS],
    sizes_int: [i32; MAX_LEVELS],
    strides: [u32; MAX_LEVELS],
}

/// One lobe sample in the frame n = +z: its direction, its weight `n.l` and its pyramid level
/// at a face centre.
#[derive(Clone, Copy)]
pub struct LobeSample {
    pub l: Vec3,
    pub weight: f32,
    pub lod: f32,
}

/// Samples per batch of the lane loops.
pub(super) const BATCH: usize = 16;

/// A lobe as structure-of-arrays batches (the last one padded with weight-0 samples).
pub struct Lobe {
    pub(super) x: Vec<[f32; BATCH]>,
    pub(super) y: Vec<[f32; BATCH]>,
    pub(super) z: Vec<[f32; BATCH]>,
    pub(super) weight: Vec<[f32; BATCH]>,
    pub(super) lod: Vec<[f32; BATCH]>,
}

impl Lobe {
    pub fn new(samples: &[LobeSample]) -> Lobe {
        let batches = samples.len().div_ceil(BATCH);
        let mut lobe = Lobe {
            x: vec![[0.0; BATCH]; batches],
            y: vec![[0.0; BATCH]; batches],
            z: vec![[1.0; BATCH]; batches],
            weight: vec![[0.0; BATCH]; batches],
            lod: vec![[0.0; BATCH]; batches],
        };
        for (i, s) in samples.iter().enumerate() {
            let (b, j) = (i / BATCH, i % BATCH);
            lobe.x[b][j] = s.l.x;
            lobe.y[b][j] = s.l.y;
            lobe.z[b][j] = s.l.z;
            lobe.weight[b][j] = s.weight;
            lobe.lod[b][j] = s.lod;
        }
        lobe
    }
}

/// One batch's bilinear reads, two per sample (slot `i` at the sample's level, slot `BATCH + i`
/// at the next), each a 2 x 2 block of one level: the first texels of its upper and lower rows
/// and the weights of its four texels (the sample's weight times the level's and the bilinear
/// weights).
pub(super) struct Reads {
    pub(super) upper: [u32; 2 * BATCH],
    pub(super) lower: [u32; 2 * BATCH],
    pub(super) w00: [f32; 2 * BATCH],
    pub(super) w10: [f32; 2 * BATCH],
    pub(super) w01: [f32; 2 * BATCH],
    pub(super) w11: [f32; 2 * BATCH],
}

impl PaddedPyramid {
    pub fn new(pyr: &[&Cubemap]) -> PaddedPyramid {
        let texels: usize = pyr.iter().map(|c| 6 * (c.size + 2) * (c.size + 2)).sum();
        assert!(pyr.len() <= MAX_LEVELS && texels < u32::MAX as usize, "a pyramid of {texels} texels");
        // Reserved whole: pushing would double the capacity past 2^k texels and copy the array
        // (for a 4096 cube, 2.1 GB copied into a 4.3 GB allocation).
        let mut rgba = Vec::with_capacity(4 * texels);
        let (mut offsets, mut sizes, mut sizes_int, mut strides) =
            ([0; MAX_LEVELS], [1.0; MAX_LEVELS], [1; MAX_LEVELS], [3; MAX_LEVELS]);
        for (l, c) in pyr.iter().enumerate() {
            let s = c.size;
            offsets[l] = (rgba.len() / 4) as u32;
            sizes[l] = s as f32;
            sizes_int[l] = s as i32;
            strides[l] = s as u32 + 2;
            for f in 0..6 {
                for y in -1..=s as i64 {
                    for x in -1..=s as i64 {
                        let [r, g, b] = c.texel(cube::seamless_texel_index(f, x, y, s));
                        rgba.extend_from_slice(&[r, g, b, 0.0]);
                    }
                }
            }
        }
        PaddedPyramid { rgba, levels: pyr.len(), offsets, sizes, sizes_int, strides }
    }

    /// The face size of level 0.
    pub fn top_size(&self) -> usize {
        if self.levels == 0 {
            0
        } else {
            self.sizes_int[0] as usize
        }
    }

    /// Trilinear read in direction `d` at level `lod_centre` plus the offset of `d`'s texel (the
    /// one-sample form of the batched loop, for tests).
    #[cfg(test)]
    fn trilinear(&self, d: Vec3, lod_centre: f32) -> Vec3 {
        let (face, a, b) = face_point_branchless(d);
        let last = self.levels - 1;
        let lod = (lod_centre + 0.75 * log2_1_to_3(1.0 + a * a + b * b)).clamp(0.0, last as f32);
        let l0 = round_to_int(lod - 0.5).clamp(0, last as i32) as usize;
        let t = lod - l0 as f32;
        let (u, v) = ((a + 1.0) * 0.5, (b + 1.0) * 0.5);
        let read = |l: usize, w: f32| {
            let (upper, lower, [w00, w10, w01, w11]) = block(self.level(l as u32), face, u, v, w);
            let (mut up, mut low) = ([0.0f32; 8], [0.0f32; 8]);
            self.accumulate(upper, lower, [w00, w10], [w01, w11], &mut up, &mut low);
            Vec3::from_array(block_rgb(&up, &low))
        };
        let mut out = read(l0, 1.0 - t);
        if t > 0.0 {
            out += read((l0 + 1).min(last), t);
        }
        out
    }

    /// The lobe's weighted mean around the unit direction `n` (tangents `t`, `b`): the batched
    /// loop, compiled for AVX-512 or AVX2 and FMA at those levels (`lobe_mean_at`, at
    /// [`crate::cpu::level`]).
    pub fn lobe_mean(&self, n: DVec3, t: DVec3, b: DVec3, lobe: &Lobe) -> [f32; 3] {
        lobe_mean_at(crate::cpu::level(), self, [t.as_vec3(), b.as_vec3(), n.as_vec3()], lobe)
    }

    /// The batched loop. Per batch, as arithmetic over arrays (vectorised): the lanes' face
    /// points and levels, then each lane's two reads (its level's with weight `w (1 - t)`, the
    /// next level's with weight `w t`), their blocks and bilinear weights. Then the reads are
    /// listed without a branch (the next level's only when `t > 0`: most reads of the sharp
    /// levels are at level 0 exactly) and summed without one: two 8-float loads (a row's two
    /// texels) each, weighted into the two rows' sums.
    #[inline(always)]
    fn lobe_mean_lanes(&self, [t, b, n]: [Vec3; 3], lobe: &Lobe) -> [f32; 3] {
        let (mut upper, mut lower) = ([0.0f32; 8], [0.0f32; 8]);
        let mut total = 0.0f32;
        for k in 0..lobe.weight.len() {
            let lw = &lobe.weight[k];
            let (reads, list, count) = self.batch_reads([t, b, n], lobe, k, lw);
            for &w in lw {
                total += w;
            }
            for &r in &list[..count] {
                let r = r as usize;
                let (w00, w10, w01, w11) = (reads.w00[r], reads.w10[r], reads.w01[r], reads.w11[r]);
                self.accumulate(reads.upper[r], reads.lower[r], [w00, w10], [w01, w11], &mut upper, &mut lower);
            }
        }
        if total > 0.0 {
            block_rgb(&upper, &lower).map(|v| v / total)
        } else {
            [0.0; 3]
        }
    }

    /// Batch `k` of `lobe` in the frame `[t, b, n]` as bilinear reads (`Reads`): per sample, its
    /// face point and level, a read at that level with weight `weight (1 - t)` in slot `i` and
    /// one at the next with `weight t` in slot `BATCH + i`; then the slots to sum, listed without
    /// a branch (the next level's only when `t > 0`), and their count.
    #[inline(always)]
    pub(super) fn batch_reads(
        &self,
        [t, b, n]: [Vec3; 3],
        lobe: &Lobe,
        k: usize,
        weights: &[f32; BATCH],
    ) -> (Reads, [u8; 2 * BATCH], usize) {
        let last = (self.levels - 1) as u32;
        let top = last as f32;
        let mut reads = Reads {
            upper: [0; 2 * BATCH],
            lower: [0; 2 * BATCH],
            w00: [0.0; 2 * BATCH],
            w10: [0.0; 2 * BATCH],
            w01: [0.0; 2 * BATCH],
            w11: [0.0; 2 * BATCH],
        };
        let (lx, ly, lz, lw, llod) = (&lobe.x[k], &lobe.y[k], &lobe.z[k], weights, &lobe.lod[k]);
        // per slot (as `Reads`, the lane's face point in both slots): its level and weight
        let mut faces = [0u32; 2 * BATCH];
        let (mut u, mut v) = ([0.0f32; 2 * BATCH], [0.0f32; 2 * BATCH]);
        let mut level = [0u32; 2 * BATCH];
        let mut weight = [0.0f32; 2 * BATCH];
        let mut level_t = [0.0f32; BATCH];
        let (mut dx, mut dy, mut dz) = ([0.0f32; BATCH], [0.0f32; BATCH], [0.0f32; BATCH]);
        for i in 0..BATCH {
            dx[i] = t.x * lx[i] + b.x * ly[i] + n.x * lz[i];
            dy[i] = t.y * lx[i] + b.y * ly[i] + n.y * lz[i];
            dz[i] = t.z * lx[i] + b.z * ly[i] + n.z * lz[i];
        }
        for i in 0..BATCH {
            let (face, fa, fb) = face_point_branchless(Vec3::new(dx[i], dy[i], dz[i]));
            let lod = (llod[i] + 0.75 * log2_1_to_3(1.0 + fa * fa + fb * fb)).clamp(0.0, top);
            // The level below (or at a whole `lod`, possibly the one below that, read with weight 0).
            let l0 = round_to_int(lod - 0.5).max(0).min(last as i32) as u32;
            let tl = lod - l0 as f32;
            level_t[i] = tl;
            level[i] = l0;
            level[BATCH + i] = (l0 + 1).min(last);
            weight[i] = lw[i] * (1.0 - tl);
            weight[BATCH + i] = lw[i] * tl;
            (faces[i], faces[BATCH + i]) = (face, face);
            (u[i], v[i]) = ((fa + 1.0) * 0.5, (fb + 1.0) * 0.5);
            (u[BATCH + i], v[BATCH + i]) = (u[i], v[i]);
        }
        // Each slot's level from the tables, then the blocks as arithmetic over the slots.
        let mut levels = [LevelShape { size: 1.0, last_corner: 0, stride: 0, offset: 0 }; 2 * BATCH];
        for r in 0..2 * BATCH {
            levels[r] = self.level(level[r]);
        }
        for r in 0..2 * BATCH {
            let (up, low, w) = block(levels[r], faces[r], u[r], v[r], weight[r]);
            (reads.upper[r], reads.lower[r]) = (up, low);
            (reads.w00[r], reads.w10[r], reads.w01[r], reads.w11[r]) = (w[0], w[1], w[2], w[3]);
        }
        let mut list = [0u8; 2 * BATCH];
        let mut count = 0;
        for (i, &tl) in level_t.iter().enumerate() {
            list[count] = i as u8;
            list[count + 1] = (BATCH + i) as u8;
            count += 1 + usize::from(tl > 0.0);
        }
        (reads, list, count)
    }

    /// Level `l`'s shape, from the tables.
    #[inline(always)]
    fn level(&self, l: u32) -> LevelShape {
        let l = l as usize % MAX_LEVELS;
        LevelShape {
            size: self.sizes[l],
            last_corner: self.sizes_int[l],
            stride: self.strides[l],
            offset: self.offsets[l],
        }
    }

    /// Adds the 2 x 2 block whose rows start at texels `upper` and `lower`, weighted by `wu`
    /// (the upper row's left and right texels) and `wl`, to the two rows' sums.
    #[inline(always)]
    pub(super) fn accumulate(
        &self,
        upper: u32,
        lower: u32,
        wu: [f32; 2],
        wl: [f32; 2],
        up: &mut [f32; 8],
        low: &mut [f32; 8],
    ) {
        let (i, j) = (4 * upper as usize, 4 * lower as usize);
        let top: &[f32; 8] = self.rgba[i..i + 8].try_into().expect("8 floats");
        let bottom: &[f32; 8] = self.rgba[j..j + 8].try_into().expect("8 floats");
        for c in 0..8 {
            up[c] += wu[c / 4] * top[c];
            low[c] += wl[c / 4] * bottom[c];
        }
    }
}

/// A pyramid level as the blocks need it: its face size, the last first column (or row) of a
/// block (the size: a block then reaches the border), its padded stride and its first texel.
#[derive(Clone, Copy)]
struct LevelShape {
    size: f32,
    last_corner: i32,
    stride: u32,
    offset: u32,
}

/// The 2 x 2 block of a bilinear read of `level` at face point (face, u, v) (u, v in [0, 1] keep
/// it inside the padded face) with weight `w`: the first texels of its upper and lower rows and
/// the weights of its texels (upper left, upper right, lower left, lower right).
#[inline(always)]
fn block(level: LevelShape, face: u32, u: f32, v: f32, w: f32) -> (u32, u32, [f32; 4]) {
    let LevelShape { size, last_corner, stride, offset } = level;
    let fx = u * size + 0.5;
    let fy = v * size + 0.5;
    // floor(fx), or fx - 1 at a whole fx (then read with weight 0): the same value. `max` and
    // `min`, not `clamp` (whose check that min <= max is a branch that stops the vectorising).
    let x0 = round_to_int(u * size).max(0).min(last_corner);
    let y0 = round_to_int(v * size).max(0).min(last_corner);
    let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
    let upper = offset + (face * stride + y0 as u32) * stride + x0 as u32;
    let (w0, w1) = (w * (1.0 - ty), w * ty);
    (upper, upper + stride, [w0 * (1.0 - tx), w0 * tx, w1 * (1.0 - tx), w1 * tx])
}

/// The RGB of a block's two row sums (each a row's two RGBA texels, [`PaddedPyramid::accumulate`]'s):
/// each channel's texels added within a row, then the rows, in that order at every level.
#[inline(always)]
pub(super) fn block_rgb(up: &[f32; 8], low: &[f32; 8]) -> [f32; 3] {
    [0, 1, 2].map(|c| (up[c] + up[c + 4]) + (low[c] + low[c + 4]))
}

crate::cpu::dispatch! {
    #[levels(Avx512, Avx2)]
    /// [`PaddedPyramid::lobe_mean_lanes`] of `pyramid` in the frame `[t, b, n]`, compiled for
    /// AVX-512, for AVX2 and FMA, and for the baseline: the same bits at every level.
    #[inline]
    fn lobe_mean_at(pyramid: &PaddedPyramid, frame: [Vec3; 3], lobe: &Lobe) -> [f32; 3] =
        PaddedPyramid::lobe_mean_lanes;
}

/// `geometry::cubemap::direction_to_face` in f32 with selects instead of branches, for the lane
/// loops (the same faces, ties and coordinates; tested against it).
#[inline(always)]
fn face_point_branchless(d: Vec3) -> (u32, f32, f32) {
    let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
    let x_major = ax >= ay && ax >= az;
    let y_major = !x_major && ay >= az;
    let sel = |c: bool, p: f32, q: f32| if c { p } else { q };
    let m = sel(x_major, ax, sel(y_major, ay, az));
    let face_x = sel(d.x > 0.0, 0.0, 1.0);
    let face_y = sel(d.y > 0.0, 2.0, 3.0);
    let face_z = sel(d.z > 0.0, 4.0, 5.0);
    let face = sel(x_major, face_x, sel(y_major, face_y, face_z));
    let a = sel(x_major, sel(d.x > 0.0, -d.z, d.z), sel(y_major, d.x, sel(d.z > 0.0, d.x, -d.x)));
    let b = sel(x_major, -d.y, sel(y_major, sel(d.y > 0.0, d.z, -d.z), -d.y));
    let inv = sel(m > 0.0, 1.0 / m, 0.0);
    (face as u32, (a * inv).clamp(-1.0, 1.0), (b * inv).clamp(-1.0, 1.0))
}

/// `x` rounded to an integer (ties to even) for |x| < 2^22, by the float's bits: `x + 1.5 2^23`
/// has a unit last place, so its mantissa holds the rounded value. A float-to-integer `as`
/// conversion (saturating, NaN to 0) is not vectorised at AVX2 and cost a quarter of the loop.
#[inline(always)]
fn round_to_int(x: f32) -> i32 {
    (x + 12_582_912.0).to_bits() as i32 - 0x4b40_0000
}

/// log2 of x in [1, 3]: the exponent plus a cubic in the mantissa m in [1, 2) (least-squares
/// fit of log2 m; error below 1.5e-3, test).
#[inline(always)]
fn log2_1_to_3(x: f32) -> f32 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    e as f32 + ((0.153_918_48 * m - 1.029_522) * m + 3.010_784) * m - 2.133_847_7
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::Level;

    /// Trilinear lookup in a pyramid (level 0 the finest) at a fractional level.
    fn reference_trilinear(pyr: &[Cubemap], d: DVec3, lod_centre: f64) -> [f64; 3] {
        let top = (pyr.len() - 1) as f64;
        let fab = cube::direction_to_face(d);
        // The texel at (a, b) subtends (1 + a^2 + b^2)^(-3/2) of a face-centre texel.
        let lod = (lod_centre + 0.75 * (1.0 + fab.1 * fab.1 + fab.2 * fab.2).log2()).clamp(0.0, top);
        let l0 = lod.floor() as usize;
        let t = lod - l0 as f64;
        let a = pyr[l0].bilinear_at(fab);
        if t == 0.0 || l0 + 1 >= pyr.len() {
            return a;
        }
        let b = pyr[l0 + 1].bilinear_at(fab);
        [0, 1, 2].map(|k| a[k] * (1.0 - t) + b[k] * t)
    }

    /// The kernel reads what the f64 lookup reads, to f32 rounding, at every level and across
    /// every face edge (a random map, random directions and levels).
    #[test]
    fn kernel_matches_the_f64_lookup() {
        let mut state = 99u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut c = Cubemap::new(16);
        for v in c.data.iter_mut() {
            *v = (0.1 + 10.0 * next()) as f32;
        }
        let pyr = crate::maths::ibl::prefilter::pyramid(&c);
        let padded = PaddedPyramid::new(&pyr.iter().collect::<Vec<_>>());
        let mut worst = 0.0f64;
        for _ in 0..20000 {
            let d = DVec3::new(2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0);
            let lod = 6.0 * next() - 1.0;
            let want = reference_trilinear(&pyr, d, lod);
            let got = padded.trilinear(d.as_vec3(), lod as f32);
            // The batched loop, one sample in the frame whose normal is d.
            let lobe = Lobe::new(&[LobeSample { l: Vec3::Z, weight: 1.0, lod: lod as f32 }]);
            let dn = d.normalize();
            let (tt, bb) = crate::maths::brdf::ggx::basis(dn);
            let batched = padded.lobe_mean(dn, tt, bb, &lobe);
            for k in 0..3 {
                worst = worst.max((batched[k] as f64 - want[k]).abs() / want[k]);
            }
            for k in 0..3 {
                worst = worst.max((got[k] as f64 - want[k]).abs() / want[k]);
            }
        }
        // The cubic log2 moves the level by up to 1.1e-3 (0.75 x 1.5e-3): up to 1e-3 of the
        // difference between two levels' reads.
        eprintln!("kernel vs f64 lookup: worst relative difference {worst:.2e}");
        assert!(worst < 4e-3, "{worst}");
    }

    /// Every level the processor has gives the portable bits (the same loop, compiled for each).
    #[test]
    fn every_level_gives_the_portable_bits() {
        let levels = crate::cpu::tested_levels();
        let mut state = 5u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut c = Cubemap::new(8);
        for v in c.data.iter_mut() {
            *v = (0.1 + 10.0 * next()) as f32;
        }
        let pyr = crate::maths::ibl::prefilter::pyramid(&c);
        let padded = PaddedPyramid::new(&pyr.iter().collect::<Vec<_>>());
        // 37 samples: two full batches and a padded one.
        let samples: Vec<LobeSample> = (0..37)
            .map(|_| {
                let l = DVec3::new(2.0 * next() - 1.0, 2.0 * next() - 1.0, next()).normalize().as_vec3();
                LobeSample { l, weight: l.z, lod: (5.0 * next() - 0.5) as f32 }
            })
            .collect();
        let lobe = Lobe::new(&samples);
        for _ in 0..500 {
            let n = DVec3::new(2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0).normalize();
            let (t, b) = crate::maths::brdf::ggx::basis(n);
            let frame = [t.as_vec3(), b.as_vec3(), n.as_vec3()];
            let portable = lobe_mean_at(Level::Portable, &padded, frame, &lobe);
            for &level in &levels {
                let got = lobe_mean_at(level, &padded, frame, &lobe);
                assert_eq!(got.map(f32::to_bits), portable.map(f32::to_bits), "{level} at {n}");
            }
        }
    }

    #[test]
    fn log2_cubic_is_close() {
        let worst =
            (0..=2000).map(|i| 1.0 + i as f32 / 1000.0).map(|x| (log2_1_to_3(x) - x.log2()).abs()).fold(0.0, f32::max);
        assert!(worst < 1.5e-3, "{worst}");
    }

    #[test]
    fn faces_match_the_f64_rule() {
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..10000 {
            let d = DVec3::new(next(), next(), next());
            let (f, a, b) = cube::direction_to_face(d);
            let (g, x, y) = face_point_branchless(d.as_vec3());
            assert_eq!(f, g as usize, "{d}");
            assert!((a as f32 - x).abs() < 1e-5 && (b as f32 - y).abs() < 1e-5);
        }
    }
}
