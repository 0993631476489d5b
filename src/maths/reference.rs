//! The exact irradiance of a piecewise-constant lat-long map: the answer every estimator in
//! hdrflow is measured against.
//!
//! For a W x H map with texel radiance `L_i`, texel-centre direction `d_i` and midpoint solid
//! angle `dOmega_i = (2 pi / W)(pi / H) sin(theta_i)` (conventions of [`crate::maths::latlong`]),
//! the irradiance at a unit normal `n` is
//!
//! ```text
//! E(n) = sum_i L_i dOmega_i max(n . d_i, 0)
//! ```
//!
//! the midpoint-rule value of `int L(w) max(n.w, 0) dw` (Lambert's cosine law; pbrt-v4 section
//! 4.1.3, "irradiance"). It is exactly the expectation of the light-sampling estimators that draw
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
//! - an inner loop without branches (`max(dot, 0) * w`, 8 lanes), compiled for AVX when the CPU
//!   has it and SSE2 otherwise: every lane performs the same f32 operations in the same order
//!   (no FMA), so the result is identical on every x86_64 CPU and whatever the number of threads;
//! - rayon over chunks of normals; within a chunk, blocks outer and normals inner, so a block
//!   (6 KiB) stays in L1 while the chunk's normals use it.
//!
//! # Accuracy
//!
//! Each block's sum is formed in f32 (8 lanes of 32 sequential additions, then a fixed pairwise
//! sum of the lanes) and added into f64 accumulators. With `u = 2^-24`, the standard bound for
//! recursive summation (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 2002,
//! section 4.2: `|error| <= gamma_{n-1} sum |t_i|`, `gamma_k = k u / (1 - k u)`) gives, per block,
//! `|S_f32 - S| <= ~35 u sum_block |t_i| + ~7 u sum_{block, |n.d_i| < 5u} |w_i|`: 31 additions
//! per lane plus 3 for the lanes, one rounding each for `w_i` and the product, and ~5 u on the
//! cosine (f32 inputs and the 3-term dot product) which only matters where `n.d` is within 5u of
//! 0. The f64 sum of the (W H / 256) block sums adds `~(W H / 256) 2^-53` relative, negligible.
//! So for non-negative radiance the relative error is at most ~2.1e-6 (worst case, all roundings
//! aligned); rounding errors being independent, a typical error is ~1e-7 (the tests compare with
//! a naive f64 loop to 1e-6). Radiance times solid angle must stay within f32 range
//! (|L| below ~1e37), and texels must be finite: a NaN or infinite texel makes non-finite (at
//! least) the normals that face it (see [`first_non_finite`]).

use std::f64::consts::PI;

use rayon::prelude::*;

use crate::data::Image;
use crate::maths::latlong;
use crate::maths::relight::SphereView;

/// Texels per block: the unit of f32 accumulation and of culling.
pub const BLOCK: usize = 256;
/// Lanes of the inner loop (one AVX register of f32).
const LANES: usize = 8;
/// Groups of `LANES` texels per block.
const GROUPS_PER_BLOCK: usize = BLOCK / LANES;
/// Side of the map tiles that blocks are filled from (TILE^2 = BLOCK).
const TILE: usize = 16;
/// Normals per parallel task (and per culling cone).
const NORMAL_CHUNK: usize = 128;
/// Normals processed together against one group of texels (register blocking: the texel loads
/// are shared; each normal's arithmetic is unchanged, so results do not depend on it).
const NORMALS_AT_ONCE: usize = 4;
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
            for y in ty..(ty + TILE).min(h) {
                let (st, ct, d_omega) = rows[y];
                for x in tx..(tx + TILE).min(w) {
                    let l = env.rgb(x, y);
                    if l == [0.0f32; 3] {
                        continue;
                    }
                    let (sp, cp) = cols[x];
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

/// `sum_j max(n_k . d_j, 0) * w_j` over one block for `K` normals at once (f32, lanes).
/// `max` is written `if d > 0 { d } else { 0 }`, which compiles to MAXPS (NaN, -0 -> +0).
#[inline(always)]
fn block_sums<const K: usize>(groups: &[Group], n: &[[f32; 3]; K]) -> [[f32; 3]; K] {
    let mut acc = [[[0.0f32; LANES]; 3]; K];
    for g in groups {
        for k in 0..K {
            for l in 0..LANES {
                let d = n[k][0] * g.dx[l] + n[k][1] * g.dy[l] + n[k][2] * g.dz[l];
                let c = if d > 0.0 { d } else { 0.0 };
                acc[k][0][l] += c * g.wr[l];
                acc[k][1][l] += c * g.wg[l];
                acc[k][2][l] += c * g.wb[l];
            }
        }
    }
    let mut out = [[0.0f32; 3]; K];
    for k in 0..K {
        for ch in 0..3 {
            out[k][ch] = hsum(&acc[k][ch]);
        }
    }
    out
}

/// One chunk of normals: for every non-culled block, every normal's block sum (f32) added into
/// its f64 accumulator, blocks in increasing order.
#[inline(always)]
fn chunk_generic(packed: &Packed, active: &[usize], normals: &[[f32; 3]], out: &mut [[f64; 3]]) {
    for &b in active {
        let groups = &packed.groups[b * GROUPS_PER_BLOCK..(b + 1) * GROUPS_PER_BLOCK];
        let mut i = 0;
        while i + NORMALS_AT_ONCE <= normals.len() {
            let n: &[[f32; 3]; NORMALS_AT_ONCE] =
                normals[i..i + NORMALS_AT_ONCE].try_into().expect("slice of NORMALS_AT_ONCE");
            let s = block_sums::<NORMALS_AT_ONCE>(groups, n);
            for k in 0..NORMALS_AT_ONCE {
                for ch in 0..3 {
                    out[i + k][ch] += s[k][ch] as f64;
                }
            }
            i += NORMALS_AT_ONCE;
        }
        while i < normals.len() {
            let s = block_sums::<1>(groups, &[normals[i]]);
            for ch in 0..3 {
                out[i][ch] += s[0][ch] as f64;
            }
            i += 1;
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn chunk_avx(packed: &Packed, active: &[usize], normals: &[[f32; 3]], out: &mut [[f64; 3]]) {
    chunk_generic(packed, active, normals, out)
}

/// Which compilation of the inner loop runs (all give bit-identical results).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx,
}

impl Kernel {
    fn detect() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx") {
            return Kernel::Avx;
        }
        Kernel::Portable
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
        match kernel {
            Kernel::Portable => chunk_generic(&packed, &active, &nf, acc),
            // SAFETY: `Kernel::Avx` is only chosen when `is_x86_feature_detected!("avx")`.
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx => unsafe { chunk_avx(&packed, &active, &nf, acc) },
        }
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
        // The clamped cosine's kink makes the midpoint rule err by up to ~1e-4 at this size.
        assert!(worst < 1e-4, "{worst}");

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
        assert!(worst < 1e-4, "{worst}");
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

    #[test]
    fn matches_naive_f64_sum_to_1e6() {
        for &(w, h, seed) in &[(48usize, 24usize, 1u64), (100, 37, 2), (3, 1, 3), (1, 2, 4)] {
            let env = random_map(w, h, seed);
            let mut ns = normals_for_tests();
            ns.push([0.6, 0.0, 0.8]);
            let fast = irradiance_exact(&env, &ns);
            let mut worst = 0.0f64;
            for (n, f) in ns.iter().zip(&fast) {
                let want = naive(&env, *n);
                for ch in 0..3 {
                    let err = (f[ch] - want[ch]).abs();
                    let scale = want[ch].abs().max(1e-300);
                    if want[ch] == 0.0 {
                        assert_eq!(f[ch], 0.0, "{w}x{h} n {n:?}");
                    } else {
                        worst = worst.max(err / scale);
                    }
                }
            }
            eprintln!("random {w}x{h}: worst relative difference to naive f64 {worst:.2e}");
            assert!(worst < 1e-6, "{w}x{h}: {worst}");
        }
    }

    #[test]
    fn culling_and_kernels_change_no_bit() {
        let env = random_map(200, 100, 7);
        let view = SphereView::new(40, [0.2, 0.5, -0.8]);
        let ns: Vec<[f64; 3]> = disc_pixels_tiled(&view).iter().map(|p| p.1).collect();
        let culled = irradiance_exact_with(&env, &ns, Kernel::Portable, true);
        let plain = irradiance_exact_with(&env, &ns, Kernel::Portable, false);
        assert!(culled.iter().zip(&plain).all(|(a, b)| (0..3).all(|c| a[c].to_bits() == b[c].to_bits())));
        let fast = irradiance_exact(&env, &ns);
        assert!(fast.iter().zip(&plain).all(|(a, b)| (0..3).all(|c| a[c].to_bits() == b[c].to_bits())));
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
        let sky = crate::formats::builtin::builtin("sky").unwrap();
        let big = crate::ops::image::resize::resize(&sky, 1024, 512);
        let t = std::time::Instant::now();
        let img = reference_sphere(&big, &view, [1.0; 3]);
        eprintln!("reference_sphere 256x256 vs sky resized to 1024x512: {:.2} s", t.elapsed().as_secs_f64());
        std::hint::black_box(img);
    }
}
