//! The exact irradiance of a piecewise-constant lat-long map: the answer every estimator in
//! hdrflow is measured against.
//!
//! For a W x H map with texel radiance `L_i`, texel-centre direction `d_i` and midpoint solid
//! angle `dOmega_i = (2 pi / W)(pi / H) sin(theta_i)` (conventions of [`crate::geometry::latlong`]),
//! the irradiance at a unit normal `n` is
//!
//! ```text
//! E(n) = sum_i L_i dOmega_i max(n . d_i, 0)
//! ```
//!
//! the midpoint-rule value of `int L(w) max(n.w, 0) dw` (irradiance from radiance: pbrt-v4
//! section 4.2, "Working with Radiometric Integrals"). It is exactly the expectation of the light-sampling estimators that draw
//! texel centres with the `Distribution2D` pdf (`Sample` + `RelightSphere` with `Unbiased`,
//! `per_pixel` with `Environment`): `E[L cos / pdf] = sum_i P_i L_i cos_i dOmega_i / P_i`. The
//! integral of the piecewise-constant map over exact directions differs from it by the midpoint
//! rule only, O(1/H^2) relative.
//!
//! A diffuse surface of albedo `a` then reflects `Lo(n) = (a / pi) E(n)` ([`reference_sphere`]).
//!
//! # Speed
//!
//! The sum is brute force, O(normals x texels) (a 256 x 256 sphere against a 1024 x 512 map is
//! 2.7e10 terms), made fast by:
//! - skipping texels whose radiance is zero in every channel (they add exactly 0);
//! - packing texels in structure-of-arrays f32 (dx, dy, dz, L dOmega per channel), grouped in
//!   blocks of [`BLOCK`] = 256 texels taken from 16 x 16 tiles of the map, so each block covers a
//!   small cone of directions;
//! - culling per block and per chunk of normals: when every texel of a block is behind every
//!   normal of the chunk (bounding cones, with a margin far above f32 rounding), the block's
//!   terms are all exactly `+0`, so skipping it changes no bit of the result;
//! - an inner loop without branches (`max(dot, 0) * w`, 8 lanes): AVX intrinsics (two normals
//!   per pass, sharing the texel loads) when the CPU has AVX, SSE2 otherwise, a portable loop
//!   elsewhere. Every lane performs the same f32 operations in the same order (no FMA), so the
//!   result is identical on every CPU and whatever the number of threads;
//! - rayon over chunks of normals; within a chunk, blocks outer and normals inner, so a block
//!   (6 KiB) stays in L1 while the chunk's normals use it.
//!
//! # Accuracy
//!
//! Each block's sum is formed in f32 (8 lanes of 32 sequential additions, then a fixed pairwise
//! sum of the lanes) and added into f64 accumulators. With `u = 2^-24`:
//! - the inputs: `n`, `d_i` and `w_i = L_i dOmega_i` rounded to f32 (relative `u` each) and the
//!   3-term dot product make each cosine wrong by at most ~5u = 3e-7 absolute (`|n| = |d| = 1`);
//!   this only matters for texels that face `n` (or nearly: `n.d > -3e-7`);
//! - the summation: recursive summation of k terms errs by at most `gamma_{k-1} sum |t_i|`,
//!   `gamma_k = k u / (1 - k u)` (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd
//!   ed., 2002, section 4.2): 31 additions per lane, 3 for the lanes, one rounding for the
//!   product: ~35 u = 2.1e-6 of `sum_block |t_i|`;
//! - the f64 sum of the `W H / 256` block sums adds `~(W H / 256) 2^-53` relative: negligible.
//!
//! So `|E_computed - E| <= ~2.1e-6 E_abs + ~3e-7 sum_{i facing n} |L_i| dOmega_i`, where `E_abs`
//! is the same sum with `|L|`. For non-negative radiance that is a few 1e-6 relative in the
//! worst case (all roundings aligned; the second term is ~2 x 3e-7 E for light spread over the
//! hemisphere, but large relative to E when only grazing texels light `n`). Roundings being
//! independent, typical errors are ~1e-7 (the tests compare with a naive f64 loop to 1e-6).
//! Radiance times solid angle must stay within f32 range (|L| below ~1e37), and texels must be
//! finite: a NaN or infinite texel makes non-finite (at least) the normals that face it (see
//! [`first_non_finite`]).

use std::f64::consts::PI;

use rayon::prelude::*;

use crate::data::Image;
use crate::geometry::latlong;
use crate::maths::relight::SphereView;

/// Texels per block: the unit of f32 accumulation and of culling.
pub const BLOCK: usize = 256;
/// Lanes of the inner loop (one AVX register of f32).
const LANES: usize = 8;
/// Groups of `LANES` texels per block.
const GROUPS_PER_BLOCK: usize = BLOCK / LANES;
/// Side of the map tiles that blocks are filled from (TILE^2 = BLOCK).
const TILE: usize = 16;
/// Normals per parallel task and per culling cone (with `reference_sphere`, one 16 x 16 tile of
/// pixels). Larger chunks cull less; smaller ones stream the packed map from memory more often.
/// 256 and 512 were the fastest of 64..1024 on 2 cores (on a busy machine: timings varied 2x).
const NORMAL_CHUNK: usize = 256;
/// Extra angle (radians) a block must lie beyond the horizon of a chunk of normals to be
/// culled: it guarantees `n.d < -sin(1e-3)` in exact arithmetic, far beyond the ~1e-6 error of
/// the f32 dot product, so a culled block's terms are all exactly +0.
const CULL_MARGIN: f64 = 1e-3;

/// Eight texels in structure-of-arrays form (direction and `L * dOmega` per channel).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Group {
    dx: [f32; LANES],
    dy: [f32; LANES],
    dz: [f32; LANES],
    wr: [f32; LANES],
    wg: [f32; LANES],
    wb: [f32; LANES],
}

/// A cone of directions: unit axis and half-angle (radians). `half_angle >= PI` means "anything".
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: [f64; 3],
    half_angle: f64,
}

const ANY_DIRECTION: Cone = Cone { axis: [0.0, 1.0, 0.0], half_angle: PI };

/// The map packed for the inner loop: `groups.len() == cones.len() * GROUPS_PER_BLOCK`, the
/// last block padded with zero texels (direction 0, weight 0: they add exactly 0).
struct Packed {
    groups: Vec<Group>,
    cones: Vec<Cone>,
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The first texel (x, y, value) of `env` that is NaN or infinite, in row-major order.
pub fn first_non_finite(env: &Image) -> Option<(usize, usize, f32)> {
    let c = env.channels.max(1);
    env.data
        .iter()
        .position(|v| !v.is_finite())
        .map(|i| ((i / c) % env.width.max(1), i / c / env.width.max(1), env.data[i]))
}

/// The smallest cone (approximately: axis = normalised mean) containing `dirs`, or
/// [`ANY_DIRECTION`] when some direction is zero or not finite, or the mean is ~0.
fn bounding_cone(dirs: impl Iterator<Item = [f64; 3]> + Clone) -> Cone {
    let mut sum = [0.0f64; 3];
    let mut count = 0usize;
    for d in dirs.clone() {
        let len = dot(d, d).sqrt();
        if !(len > 0.0) || !len.is_finite() {
            return ANY_DIRECTION;
        }
        for k in 0..3 {
            sum[k] += d[k] / len;
        }
        count += 1;
    }
    let len = dot(sum, sum).sqrt();
    if count == 0 || !(len > 1e-6 * count as f64) {
        return ANY_DIRECTION;
    }
    let axis = [sum[0] / len, sum[1] / len, sum[2] / len];
    let mut half_angle = 0.0f64;
    for d in dirs {
        let c = dot(d, axis) / dot(d, d).sqrt();
        half_angle = half_angle.max(c.clamp(-1.0, 1.0).acos());
    }
    // acos near 1 loses ~1e-8 rad; 1e-6 covers it.
    Cone { axis, half_angle: half_angle + 1e-6 }
}

/// True when every direction of `block` is at more than 90 degrees (+ margin) from every
/// direction of `normals`: then `max(n.d, 0)` is exactly 0 for all pairs, even in f32.
#[inline]
fn behind(normals: &Cone, block: &Cone) -> bool {
    if normals.half_angle >= PI || block.half_angle >= PI {
        return false;
    }
    let gamma = dot(normals.axis, block.axis).clamp(-1.0, 1.0).acos();
    gamma - normals.half_angle - block.half_angle > 0.5 * PI + CULL_MARGIN
}

/// Packs the non-zero texels of `env` tile by tile into blocks (see the module documentation).
fn pack(env: &Image) -> Packed {
    let (w, h) = (env.width, env.height);
    // Row and column trigonometry once: d = (-sin t sin p, cos t, sin t cos p).
    let rows: Vec<(f64, f64, f64)> = (0..h)
        .map(|y| {
            let (st, ct) = latlong::theta_of_row(y, h).sin_cos();
            (st, ct, latlong::texel_solid_angle(y, w, h))
        })
        .collect();
    let cols: Vec<(f64, f64)> = (0..w).map(|x| latlong::phi_of_column(x, w).sin_cos()).collect();

    // Texel stream in tile order, zero texels skipped: (direction, L * dOmega).
    let mut dirs: Vec<[f64; 3]> = Vec::new();
    let mut weights: Vec<[f64; 3]> = Vec::new();
    for ty in (0..h).step_by(TILE) {
        for tx in (0..w).step_by(TILE) {
            for (y, &(st, ct, d_omega)) in rows.iter().enumerate().skip(ty).take(TILE) {
                for (x, &(sp, cp)) in cols.iter().enumerate().skip(tx).take(TILE) {
                    let l = env.rgb(x, y);
                    if l == [0.0f32; 3] {
                        continue;
                    }
                    dirs.push([-st * sp, ct, st * cp]);
                    weights.push(l.map(|c| c as f64 * d_omega));
                }
            }
        }
    }

    let blocks = dirs.len().div_ceil(BLOCK);
    let mut groups = vec![Group::default(); blocks * GROUPS_PER_BLOCK];
    for (i, (d, wt)) in dirs.iter().zip(&weights).enumerate() {
        let g = &mut groups[i / LANES];
        let l = i % LANES;
        g.dx[l] = d[0] as f32;
        g.dy[l] = d[1] as f32;
        g.dz[l] = d[2] as f32;
        g.wr[l] = wt[0] as f32;
        g.wg[l] = wt[1] as f32;
        g.wb[l] = wt[2] as f32;
    }
    let cones = (0..blocks)
        .map(|b| bounding_cone(dirs[b * BLOCK..((b + 1) * BLOCK).min(dirs.len())].iter().copied()))
        .collect();
    Packed { groups, cones }
}

/// Fixed pairwise sum of the 8 lanes.
#[inline(always)]
fn hsum(a: &[f32; LANES]) -> f32 {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// Portable inner loop (the reference for the SIMD ones): `sum_j max(n . d_j, 0) * w_j` over
/// one block, in f32, per lane `(nx dx + ny dy) + nz dz`, then `max`, then `acc += c * w`.
/// `max` is `if d > 0 { d } else { 0 }`: the semantics of MAXPS(d, 0) (NaN and -0 give +0).
#[allow(clippy::needless_range_loop)] // lane l of every array: the SIMD layout, written out
fn block_sum_portable(groups: &[Group], n: [f32; 3]) -> [f32; 3] {
    let mut acc = [[0.0f32; LANES]; 3];
    for g in groups {
        for l in 0..LANES {
            let d = n[0] * g.dx[l] + n[1] * g.dy[l] + n[2] * g.dz[l];
            let c = if d > 0.0 { d } else { 0.0 };
            acc[0][l] += c * g.wr[l];
            acc[1][l] += c * g.wg[l];
            acc[2][l] += c * g.wb[l];
        }
    }
    [hsum(&acc[0]), hsum(&acc[1]), hsum(&acc[2])]
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{hsum, Group, LANES};
    use std::arch::x86_64::*;

    /// AVX version of `block_sum_portable` for two normals at once (the texel loads are shared;
    /// each normal's lane arithmetic is exactly the portable one).
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn block_sums2_avx(groups: &[Group], a: [f32; 3], b: [f32; 3]) -> [[f32; 3]; 2] {
        let (ax, ay, az) = (_mm256_set1_ps(a[0]), _mm256_set1_ps(a[1]), _mm256_set1_ps(a[2]));
        let (bx, by, bz) = (_mm256_set1_ps(b[0]), _mm256_set1_ps(b[1]), _mm256_set1_ps(b[2]));
        let zero = _mm256_setzero_ps();
        let mut acc = [zero; 6];
        for g in groups {
            let dx = _mm256_load_ps(g.dx.as_ptr());
            let dy = _mm256_load_ps(g.dy.as_ptr());
            let dz = _mm256_load_ps(g.dz.as_ptr());
            let wr = _mm256_load_ps(g.wr.as_ptr());
            let wg = _mm256_load_ps(g.wg.as_ptr());
            let wb = _mm256_load_ps(g.wb.as_ptr());
            let da = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, dx), _mm256_mul_ps(ay, dy)), _mm256_mul_ps(az, dz));
            let db = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(bx, dx), _mm256_mul_ps(by, dy)), _mm256_mul_ps(bz, dz));
            // MAXPS returns the second operand when the first is not greater (NaN, -0 -> +0).
            let ca = _mm256_max_ps(da, zero);
            let cb = _mm256_max_ps(db, zero);
            acc[0] = _mm256_add_ps(acc[0], _mm256_mul_ps(ca, wr));
            acc[1] = _mm256_add_ps(acc[1], _mm256_mul_ps(ca, wg));
            acc[2] = _mm256_add_ps(acc[2], _mm256_mul_ps(ca, wb));
            acc[3] = _mm256_add_ps(acc[3], _mm256_mul_ps(cb, wr));
            acc[4] = _mm256_add_ps(acc[4], _mm256_mul_ps(cb, wg));
            acc[5] = _mm256_add_ps(acc[5], _mm256_mul_ps(cb, wb));
        }
        let mut lanes = [[0.0f32; LANES]; 6];
        for k in 0..6 {
            _mm256_storeu_ps(lanes[k].as_mut_ptr(), acc[k]);
        }
        [[hsum(&lanes[0]), hsum(&lanes[1]), hsum(&lanes[2])], [hsum(&lanes[3]), hsum(&lanes[4]), hsum(&lanes[5])]]
    }

    /// SSE2 version of `block_sum_portable` (lanes 0-3 and 4-7 in two registers).
    pub(super) unsafe fn block_sum_sse2(groups: &[Group], n: [f32; 3]) -> [f32; 3] {
        let (nx, ny, nz) = (_mm_set1_ps(n[0]), _mm_set1_ps(n[1]), _mm_set1_ps(n[2]));
        let zero = _mm_setzero_ps();
        let mut acc = [zero; 6]; // r lo, r hi, g lo, g hi, b lo, b hi
        for g in groups {
            for half in 0..2 {
                let o = 4 * half;
                let d = _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(nx, _mm_load_ps(g.dx.as_ptr().add(o))),
                        _mm_mul_ps(ny, _mm_load_ps(g.dy.as_ptr().add(o))),
                    ),
                    _mm_mul_ps(nz, _mm_load_ps(g.dz.as_ptr().add(o))),
                );
                let c = _mm_max_ps(d, zero);
                acc[half] = _mm_add_ps(acc[half], _mm_mul_ps(c, _mm_load_ps(g.wr.as_ptr().add(o))));
                acc[2 + half] = _mm_add_ps(acc[2 + half], _mm_mul_ps(c, _mm_load_ps(g.wg.as_ptr().add(o))));
                acc[4 + half] = _mm_add_ps(acc[4 + half], _mm_mul_ps(c, _mm_load_ps(g.wb.as_ptr().add(o))));
            }
        }
        let mut lanes = [[0.0f32; LANES]; 3];
        for ch in 0..3 {
            _mm_storeu_ps(lanes[ch].as_mut_ptr(), acc[2 * ch]);
            _mm_storeu_ps(lanes[ch].as_mut_ptr().add(4), acc[2 * ch + 1]);
        }
        [hsum(&lanes[0]), hsum(&lanes[1]), hsum(&lanes[2])]
    }
}

/// Which implementation of the inner loop runs. All give bit-identical results: each lane does
/// the same f32 operations in the same order (no FMA contraction), lanes summed in one order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))] // the tests use it on x86_64
    Portable,
    #[cfg(target_arch = "x86_64")]
    Sse2,
    #[cfg(target_arch = "x86_64")]
    Avx,
}

impl Kernel {
    fn detect() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx") {
                Kernel::Avx
            } else {
                Kernel::Sse2
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Kernel::Portable
    }

    /// One chunk of normals: for every non-culled block (in increasing order), each normal's
    /// f32 block sum added into its f64 accumulator.
    fn run(self, packed: &Packed, active: &[usize], normals: &[[f32; 3]], out: &mut [[f64; 3]]) {
        let add = |acc: &mut [f64; 3], s: [f32; 3]| {
            for ch in 0..3 {
                acc[ch] += s[ch] as f64;
            }
        };
        for &b in active {
            let groups = &packed.groups[b * GROUPS_PER_BLOCK..(b + 1) * GROUPS_PER_BLOCK];
            match self {
                Kernel::Portable => {
                    for (n, acc) in normals.iter().zip(out.iter_mut()) {
                        add(acc, block_sum_portable(groups, *n));
                    }
                }
                // SAFETY: SSE2 is part of the x86_64 baseline.
                #[cfg(target_arch = "x86_64")]
                Kernel::Sse2 => {
                    for (n, acc) in normals.iter().zip(out.iter_mut()) {
                        add(acc, unsafe { x86::block_sum_sse2(groups, *n) });
                    }
                }
                // SAFETY: `Kernel::Avx` is only chosen when `is_x86_feature_detected!("avx")`.
                #[cfg(target_arch = "x86_64")]
                Kernel::Avx => {
                    let pairs = normals.len() / 2;
                    for i in 0..pairs {
                        let s = unsafe { x86::block_sums2_avx(groups, normals[2 * i], normals[2 * i + 1]) };
                        add(&mut out[2 * i], s[0]);
                        add(&mut out[2 * i + 1], s[1]);
                    }
                    if normals.len() % 2 == 1 {
                        let i = normals.len() - 1;
                        let s = unsafe { x86::block_sums2_avx(groups, normals[i], normals[i]) };
                        add(&mut out[i], s[0]);
                    }
                }
            }
        }
    }
}

/// The exact irradiance `E(n) = sum_i L_i dOmega_i max(n . d_i, 0)` of the piecewise-constant
/// map `env` at each of `normals`, per channel (see the module documentation for the formula,
/// its speed and its accuracy). A one-channel map is read as grey.
///
/// Normals should be unit vectors (the sum is positively homogeneous in `n`: a normal of length
/// 2 gets twice the irradiance). Culling works best when consecutive normals are close to each
/// other (e.g. pixels in tile order, as [`reference_sphere`] passes them); the result does not
/// depend on the order, the chunking or the number of threads.
pub fn irradiance_exact(env: &Image, normals: &[[f64; 3]]) -> Vec<[f64; 3]> {
    irradiance_exact_with(env, normals, Kernel::detect(), true)
}

fn irradiance_exact_with(env: &Image, normals: &[[f64; 3]], kernel: Kernel, cull: bool) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0f64; 3]; normals.len()];
    if normals.is_empty() || env.width == 0 || env.height == 0 {
        return out;
    }
    let packed = pack(env);
    if packed.cones.is_empty() {
        return out;
    }
    normals.par_chunks(NORMAL_CHUNK).zip(out.par_chunks_mut(NORMAL_CHUNK)).for_each(|(ns, acc)| {
        let cone = if cull { bounding_cone(ns.iter().copied()) } else { ANY_DIRECTION };
        let active: Vec<usize> = (0..packed.cones.len()).filter(|&b| !behind(&cone, &packed.cones[b])).collect();
        let nf: Vec<[f32; 3]> = ns.iter().map(|n| n.map(|c| c as f32)).collect();
        kernel.run(&packed, &active, &nf, acc);
    });
    out
}

/// The on-disc pixels of `view` in 16 x 16 tile order: (pixel index, normal).
pub(crate) fn disc_pixels_tiled(view: &SphereView) -> Vec<(usize, [f64; 3])> {
    let size = view.size;
    let mut out = Vec::with_capacity(size * size);
    for ty in (0..size).step_by(TILE) {
        for tx in (0..size).step_by(TILE) {
            for py in ty..(ty + TILE).min(size) {
                for px in tx..(tx + TILE).min(size) {
                    if let Some(n) = view.normal_at(px, py) {
                        out.push((py * size + px, n));
                    }
                }
            }
        }
    }
    out
}

/// The exact relit diffuse sphere: `Lo = (albedo / pi) E(n)` per channel at every pixel of
/// `view`'s disc (normals from [`SphereView::normal_at`]), 0 elsewhere; `size` x `size` RGB,
/// pixel for pixel comparable with `RelightSphere` and the other sphere renderers.
pub fn reference_sphere(env: &Image, view: &SphereView, albedo: [f64; 3]) -> Image {
    let size = view.size;
    let mut image = Image::new(size, size, 3);
    let pixels = disc_pixels_tiled(view);
    let normals: Vec<[f64; 3]> = pixels.iter().map(|p| p.1).collect();
    let e = irradiance_exact(env, &normals);
    for (&(i, _), e) in pixels.iter().zip(&e) {
        for ch in 0..3 {
            image.data[i * 3 + ch] = (albedo[ch] / PI * e[ch]) as f32;
        }
    }
    image
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::maths::sequences::SplitMix64;

    /// The sum written plainly in f64, over every texel.
    pub(crate) fn naive(env: &Image, n: [f64; 3]) -> [f64; 3] {
        let mut e = [0.0f64; 3];
        for y in 0..env.height {
            let d_omega = latlong::texel_solid_angle(y, env.width, env.height);
            for x in 0..env.width {
                let d = latlong::texel_direction(x, y, env.width, env.height);
                let c = dot(n, d).max(0.0);
                let l = env.rgb(x, y);
                for ch in 0..3 {
                    e[ch] += l[ch] as f64 * d_omega * c;
                }
            }
        }
        e
    }

    /// A latlong map from a function of the texel-centre direction.
    pub(crate) fn map(w: usize, h: usize, f: impl Fn([f64; 3]) -> [f64; 3]) -> Image {
        Image::from_fn_rgb(w, h, |x, y| f(latlong::texel_direction(x, y, w, h)).map(|v| v as f32))
    }

    /// Unit directions spread over the sphere (Fibonacci lattice), including the poles' region.
    pub(crate) fn fibonacci(n: usize) -> Vec<[f64; 3]> {
        let golden = PI * (1.0 + 5f64.sqrt());
        (0..n)
            .map(|k| {
                let i = k as f64 + 0.5;
                let z = 1.0 - 2.0 * i / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i;
                [r * phi.cos(), z, r * phi.sin()]
            })
            .collect()
    }

    fn normals_for_tests() -> Vec<[f64; 3]> {
        let mut ns = fibonacci(300);
        ns.extend([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]);
        ns
    }

    #[test]
    fn constant_map_gives_pi_l_up_to_the_midpoint_rule() {
        let (w, h) = (256, 128);
        // Sum of the midpoint solid angles: (2 pi^2 / H) sum sin(theta_y) = 4 pi (pi/(2H)) /
        // sin(pi/(2H)) = 4 pi (1 + pi^2 / (24 H^2) + ...): 2.5e-5 relative for H = 128.
        let total: f64 = (0..h).map(|y| latlong::texel_solid_angle(y, w, h) * w as f64).sum();
        let predicted = 4.0 * PI * (PI / (2.0 * h as f64)) / (PI / (2.0 * h as f64)).sin();
        assert!((total - predicted).abs() < 1e-12 * total, "{total} {predicted}");
        assert!((total / (4.0 * PI) - 1.0).abs() < 3e-5);

        let l = [1.0f32, 0.5, 2.0];
        let env = Image::from_fn_rgb(w, h, |_, _| l);
        let ns = normals_for_tests();
        let e = irradiance_exact(&env, &ns);
        let mut worst = 0.0f64;
        for e in &e {
            for ch in 0..3 {
                worst = worst.max((e[ch] / (PI * l[ch] as f64) - 1.0).abs());
            }
        }
        eprintln!("constant 256x128: worst relative error {worst:.2e}");
        // The midpoint rule in theta: at the poles E = 2 pi sum sin cos dtheta, whose midpoint
        // error is (h^2 / 24) int f'' = -(h^2 / 6) E relative (f = sin(2 theta) / 2, h = pi / H):
        // 1.004e-4 for H = 128, the worst case over normals.
        let pole = (PI / h as f64).powi(2) / 6.0;
        assert!(worst < 1.05 * pole, "{worst} vs {pole}");

        // Through reference_sphere: albedo * L on the whole disc.
        let view = SphereView::new(32, [0.3, 0.4, 0.8]);
        let albedo = [0.8, 0.5, 0.25];
        let img = reference_sphere(&env, &view, albedo);
        for py in 0..32 {
            for px in 0..32 {
                let p = img.pixel(px, py);
                if view.normal_at(px, py).is_none() {
                    assert_eq!(p, &[0.0f32; 3][..]);
                } else {
                    for ch in 0..3 {
                        let want = albedo[ch] * l[ch] as f64;
                        assert!((p[ch] as f64 / want - 1.0).abs() < 1e-4, "({px},{py}) {p:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn upper_hemisphere_gives_one_plus_ny_over_two() {
        // The `hemisphere` built-in's rule at a finer size: 1 above the horizon, 0 below. The
        // horizon falls between rows, so the map is exact; the error is the midpoint rule's.
        for &(w, h, tol) in &[(64usize, 32usize, 2e-3), (256, 128, 1.5e-4)] {
            let env = map(w, h, |d| if d[1] > 0.0 { [1.0; 3] } else { [0.0; 3] });
            let ns = normals_for_tests();
            let e = irradiance_exact(&env, &ns);
            let mut worst = 0.0f64;
            for (n, e) in ns.iter().zip(&e) {
                let want = PI * (1.0 + n[1]) / 2.0;
                worst = worst.max((e[0] - want).abs() / PI);
            }
            eprintln!("hemisphere {w}x{h}: worst error {worst:.2e} (relative to pi)");
            assert!(worst < tol, "{w}x{h}: {worst}");
        }
    }

    #[test]
    fn linear_radiance_gives_pi_a_plus_two_pi_over_three_b_dot_n() {
        let a = 1.0;
        let b = [0.3, 0.5, 0.2];
        let env = map(256, 128, |d| [a + dot(b, d), 2.0 * a - dot(b, d), a]);
        let ns = normals_for_tests();
        let e = irradiance_exact(&env, &ns);
        let mut worst = 0.0f64;
        for (n, e) in ns.iter().zip(&e) {
            let want = [PI * a + 2.0 * PI / 3.0 * dot(b, *n), 2.0 * PI * a - 2.0 * PI / 3.0 * dot(b, *n), PI * a];
            for ch in 0..3 {
                worst = worst.max((e[ch] / want[ch] - 1.0).abs());
            }
        }
        eprintln!("linear 256x128: worst relative error {worst:.2e}");
        // Midpoint rule, as for the constant map (~(pi/H)^2 / 6 = 1e-4, a little more for the
        // linear term).
        assert!(worst < 1.5e-4, "{worst}");
    }

    /// A random map: one texel in five black (skipped by the packing), a few very bright.
    pub(crate) fn random_map(w: usize, h: usize, seed: u64) -> Image {
        let mut rng = SplitMix64::new(seed);
        let mut data = Vec::with_capacity(w * h * 3);
        for _ in 0..w * h {
            let r = rng.next_f64();
            let px = if r < 0.2 {
                [0.0; 3]
            } else if r > 0.98 {
                [500.0, 300.0, 100.0]
            } else {
                [rng.next_f64() as f32, rng.next_f64() as f32 * 2.0, rng.next_f64() as f32 * 0.1]
            };
            data.extend_from_slice(&px);
        }
        Image::from_vec(w, h, 3, data)
    }

    /// Against the plain f64 sum: 1e-6 relative on random maps. On degenerate maps (3 x 1,
    /// 1 x 2) a normal can see a single texel at grazing incidence, where the ~3e-7 absolute
    /// error of an f32 cosine is large relative to the cosine: there the documented bound
    /// `2.1e-6 E + 3e-7 sum_front |L| dOmega` is checked instead.
    #[test]
    fn matches_naive_f64_sum_to_1e6() {
        for &(w, h, seed, relative) in
            &[(48usize, 24usize, 1u64, true), (100, 37, 2, true), (3, 1, 3, false), (1, 2, 4, false)]
        {
            let env = random_map(w, h, seed);
            let mut ns = normals_for_tests();
            ns.push([0.6, 0.0, 0.8]);
            let fast = irradiance_exact(&env, &ns);
            let mut worst = 0.0f64;
            for (n, f) in ns.iter().zip(&fast) {
                let want = naive(&env, *n);
                // sum over texels facing n (within rounding) of |L| dOmega
                let front = {
                    let mut s = [0.0f64; 3];
                    for y in 0..h {
                        for x in 0..w {
                            if dot(*n, latlong::texel_direction(x, y, w, h)) > -1e-6 {
                                let l = env.rgb(x, y);
                                for ch in 0..3 {
                                    s[ch] += (l[ch] as f64).abs() * latlong::texel_solid_angle(y, w, h);
                                }
                            }
                        }
                    }
                    s
                };
                for ch in 0..3 {
                    let err = (f[ch] - want[ch]).abs();
                    if want[ch] == 0.0 {
                        assert_eq!(f[ch], 0.0, "{w}x{h} n {n:?}");
                    } else if relative {
                        worst = worst.max(err / want[ch].abs());
                    } else {
                        assert!(
                            err <= 2.1e-6 * want[ch].abs() + 3e-7 * front[ch],
                            "{w}x{h} n {n:?}: {} vs {}",
                            f[ch],
                            want[ch]
                        );
                    }
                }
            }
            if relative {
                eprintln!("random {w}x{h}: worst relative difference to naive f64 {worst:.2e}");
                assert!(worst < 1e-6, "{w}x{h}: {worst}");
            }
        }
    }

    #[test]
    fn culling_and_kernels_change_no_bit() {
        let env = random_map(200, 100, 7);
        let view = SphereView::new(40, [0.2, 0.5, -0.8]);
        let ns: Vec<[f64; 3]> = disc_pixels_tiled(&view).iter().map(|p| p.1).collect();
        let same = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            a.len() == b.len() && a.iter().zip(b).all(|(a, b)| (0..3).all(|c| a[c].to_bits() == b[c].to_bits()))
        };
        let plain = irradiance_exact_with(&env, &ns, Kernel::Portable, false);
        assert!(same(&plain, &irradiance_exact_with(&env, &ns, Kernel::Portable, true)));
        #[cfg(target_arch = "x86_64")]
        {
            assert!(same(&plain, &irradiance_exact_with(&env, &ns, Kernel::Sse2, true)));
            assert!(same(&plain, &irradiance_exact_with(&env, &ns, Kernel::Sse2, false)));
            if is_x86_feature_detected!("avx") {
                assert!(same(&plain, &irradiance_exact_with(&env, &ns, Kernel::Avx, true)));
                // An odd count exercises the unpaired last normal.
                let odd = &ns[..ns.len() - 1 + ns.len() % 2];
                assert!(same(&plain[..odd.len()], &irradiance_exact_with(&env, odd, Kernel::Avx, true)));
            }
        }
        let fast = irradiance_exact(&env, &ns);
        assert!(same(&fast, &plain));
        // Order and thread count do not matter either.
        let rev: Vec<[f64; 3]> = ns.iter().rev().copied().collect();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let e_rev = pool.install(|| irradiance_exact(&env, &rev));
        assert!(e_rev.iter().rev().zip(&fast).all(|(a, b)| (0..3).all(|c| a[c].to_bits() == b[c].to_bits())));
    }

    #[test]
    fn culling_skips_blocks() {
        // A map lit only near +Y and normals pointing down: everything is culled, result 0.
        let env = map(128, 64, |d| if d[1] > 0.9 { [1.0; 3] } else { [0.0; 3] });
        let e = irradiance_exact(&env, &[[0.0, -1.0, 0.0], [0.05, -0.99, 0.0]]);
        assert_eq!(e, vec![[0.0; 3]; 2]);
        let packed = pack(&env);
        let cone = bounding_cone([[0.0, -1.0, 0.0], [0.05, -0.99, 0.0]].into_iter());
        assert!(packed.cones.iter().all(|c| behind(&cone, c)));
    }

    #[test]
    fn empty_inputs_and_helpers() {
        let env = Image::new(8, 4, 3);
        assert_eq!(irradiance_exact(&env, &[[0.0, 1.0, 0.0]]), vec![[0.0; 3]]);
        assert!(irradiance_exact(&env, &[]).is_empty());
        let mut bad = Image::new(4, 2, 3);
        assert_eq!(first_non_finite(&bad), None);
        bad.pixel_mut(3, 1)[2] = f32::NAN;
        let (x, y, v) = first_non_finite(&bad).unwrap();
        assert_eq!((x, y), (3, 1));
        assert!(v.is_nan());
        let grey = Image::from_vec(2, 1, 1, vec![1.0, 1.0]);
        let e = irradiance_exact(&grey, &[[0.0, 1.0, 0.0]]);
        assert_eq!(e[0][0], e[0][2]);
        let img = reference_sphere(&grey, &SphereView::new(0, [0.0, 0.0, 1.0]), [1.0; 3]);
        assert_eq!(img.data.len(), 0);
    }

    /// Timing: `cargo test --release reference_timing -- --ignored --nocapture`.
    /// Target: a 256 x 256 sphere against a 1024 x 512 map in a few seconds on 2 cores.
    #[test]
    #[ignore]
    fn reference_timing() {
        let env = random_map(1024, 512, 11);
        let view = SphereView::new(256, latlong::direction_deg(90.0, 90.0));
        let t = std::time::Instant::now();
        let img = reference_sphere(&env, &view, [1.0; 3]);
        eprintln!(
            "reference_sphere 256x256 vs 1024x512 (random, 20% black): {:.2} s on {} threads",
            t.elapsed().as_secs_f64(),
            rayon::current_num_threads()
        );
        std::hint::black_box(img);
        // How much culling saves: the fraction of blocks kept, over the sphere's chunks.
        let packed = pack(&env);
        let ns: Vec<[f64; 3]> = disc_pixels_tiled(&view).iter().map(|p| p.1).collect();
        let kept: usize = ns
            .chunks(NORMAL_CHUNK)
            .map(|c| {
                let cone = bounding_cone(c.iter().copied());
                packed.cones.iter().filter(|b| !behind(&cone, b)).count() * c.len()
            })
            .sum();
        eprintln!("blocks kept after culling: {:.1}%", 100.0 * kept as f64 / (packed.cones.len() * ns.len()) as f64);
        let sky = crate::formats::builtin::builtin("sky").unwrap();
        let big = crate::ops::image::resize::resize(&sky, 1024, 512);
        let t = std::time::Instant::now();
        let img = reference_sphere(&big, &view, [1.0; 3]);
        eprintln!("reference_sphere 256x256 vs sky resized to 1024x512: {:.2} s", t.elapsed().as_secs_f64());
        std::hint::black_box(img);
    }
}
