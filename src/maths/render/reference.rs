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
//! - packing texels with their weight `L dOmega` in the 16-lane structure-of-arrays blocks of
//!   [`crate::maths::render::kernels`] ([`WideBlock`]), taken tile by tile from 16 x 16 tiles of the map
//!   ([`TILE_TEXELS`] = 256 per tile), so each tile covers a small cone of directions;
//! - culling per tile and per chunk of normals: when every texel of a tile is behind every normal
//!   of the chunk ([`Cone::hides`], with the margin derived in [`crate::maths::render::kernels`]), the
//!   tile's terms are all exactly `+0`, so skipping it changes no bit of the result;
//! - the inner loop of [`Kernel::accumulate_wide`], without branches (`fma(max(dot, 0), w, acc)`,
//!   16 lanes, 7 vector operations a term), at the `crate::cpu` level: AVX-512 (two normals per
//!   pass, one register per component), AVX with FMA at `avx2` (two registers per component), the
//!   portable loop at `portable`. Every lane performs the same f32 operations in the same order
//!   (fused multiply-adds, rounded once, on every CPU), so the result is identical on every CPU
//!   and whatever the number of threads. Each tile adds its 16 lane sums into f64 lane
//!   accumulators (two vector operations per channel); the lanes are summed once at the end;
//! - rayon over chunks of normals; within a chunk, tiles outer and normals inner, so a tile's
//!   blocks (6 KiB) stay in L1 while the chunk's normals use them.
//!
//! On the 2-core benchmark machine (AMD Zen 5, AVX-512, 4.1-4.2 GHz measured) a 512 x 512 sphere
//! against a 1024 x 512 map takes about 1.9 s: 1.3x the arithmetic floor of the terms it
//! evaluates (3 cycles per 16 terms per core: with FMA, 6 of the 7 vector operations a term need
//! the 2 multiply-capable pipes; `hdrflow bench --targets-only` measures both in one run) and
//! 0.8x the floor of all pixel x texel terms. The kernel itself runs at 4.4 terms per cycle on a
//! hot tile (18 terms per ns).
//!
//! # Accuracy
//!
//! Each tile's sum is formed in f32 per lane (16 lanes of 16 sequential additions) and each lane
//! sum is added into an f64 lane accumulator; the 16 lanes are summed in f64 at the end. With
//! `u = 2^-24`:
//! - the inputs: `n`, `d_i` and `w_i = L_i dOmega_i` rounded to f32 (relative `u` each) and the
//!   3-term dot product make each cosine wrong by at most ~5u = 3e-7 absolute (`|n| = |d| = 1`);
//!   this only matters for texels that face `n` (or nearly: `n.d > -3e-7`);
//! - the summation: recursive summation of k terms errs by at most `gamma_{k-1} sum |t_i|`,
//!   `gamma_k = k u / (1 - k u)` (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd
//!   ed., 2002, section 4.2): 15 fused additions per lane (the product is not rounded apart): ~16
//!   u = 1e-6 of `sum_tile |t_i|`;
//! - the f64 sums of the `W H / 256` tile lane sums add `~(W H / 256) 2^-53` relative: negligible.
//!
//! So `|E_computed - E| <= ~1e-6 E_abs + ~3e-7 sum_{i facing n} |L_i| dOmega_i`, where `E_abs`
//! is the same sum with `|L|`. For non-negative radiance that is a few 1e-6 relative in the
//! worst case (all roundings aligned; the second term is ~2 x 3e-7 E for light spread over the
//! hemisphere, but large relative to E when only grazing texels light `n`). Roundings being
//! independent, typical errors are ~1e-7 (the tests compare with a naive f64 loop to 1e-6).
//! Radiance times solid angle must stay within f32 range (|L| below ~1e37), and texels must be
//! finite: a NaN or infinite texel makes non-finite (at least) the normals that face it (see
//! [`first_non_finite`]).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::latlong_grid::LatLongGrid;
use crate::geometry::unit;
use crate::maths::render::kernels::{pack_blocks, wide_total, Cone, Kernel, WideBlock, WideSums, WIDE};
use crate::maths::render::relight::SphereView;
use crate::values::Image;

/// Side of the map tiles that texels are packed from, and of the pixel tiles of
/// [`disc_pixels_tiled`].
const TILE: usize = 16;
/// Texels per map tile (`TILE^2`): the unit of f32 accumulation and of culling.
pub const TILE_TEXELS: usize = TILE * TILE;
/// Kernel blocks per map tile.
const BLOCKS_PER_TILE: usize = TILE_TEXELS / WIDE;
/// Normals per parallel task and per culling cone (with `reference_sphere`, one 16 x 16 tile of
/// pixels). Larger chunks cull less; smaller ones stream the packed map from memory more often.
/// 256 and 512 were the fastest of 64..1024 on 2 cores (on a busy machine: timings varied 2x).
const NORMAL_CHUNK: usize = 256;

/// The map packed for the inner loop: `blocks.len() == cones.len() * BLOCKS_PER_TILE`, the last
/// tile padded with zero texels (direction 0, weight 0: they add exactly 0). A tile's cone is
/// `None` when it spans a hemisphere or more (it is never culled).
struct Packed {
    blocks: Vec<WideBlock>,
    cones: Vec<Option<Cone>>,
}

/// The first texel (x, y, value) of `env` that is NaN or infinite, in row-major order.
pub fn first_non_finite(env: &Image) -> Option<(usize, usize, f32)> {
    let c = env.channels.max(1);
    env.data
        .iter()
        .position(|v| !v.is_finite())
        .map(|i| ((i / c) % env.width.max(1), i / c / env.width.max(1), env.data[i]))
}

/// Packs the non-zero texels of `env` tile by tile into blocks (see the module documentation).
fn pack(env: &Image) -> Packed {
    let (w, h) = (env.width, env.height);
    // Row and column trigonometry once (texel directions and solid angles from the tables).
    let grid = LatLongGrid::new(w, h);

    // Texel stream in tile order, zero texels skipped: (direction, L * dOmega).
    let mut dirs: Vec<DVec3> = Vec::new();
    let mut weights: Vec<[f64; 3]> = Vec::new();
    for ty in (0..h).step_by(TILE) {
        for tx in (0..w).step_by(TILE) {
            for y in ty..(ty + TILE).min(h) {
                let d_omega = grid.midpoint_solid_angle(y);
                for x in tx..(tx + TILE).min(w) {
                    let l = env.rgb(x, y);
                    if l == [0.0f32; 3] {
                        continue;
                    }
                    dirs.push(DVec3::from(grid.centre_direction(x, y)));
                    weights.push(l.map(|c| c as f64 * d_omega));
                }
            }
        }
    }

    let tiles = dirs.len().div_ceil(TILE_TEXELS);
    let mut blocks = Vec::with_capacity(tiles * BLOCKS_PER_TILE);
    pack_blocks(dirs.iter().zip(&weights).map(|(d, wt)| (d.as_vec3().to_array(), wt.map(|c| c as f32))), &mut blocks);
    blocks.resize(tiles * BLOCKS_PER_TILE, WideBlock::ZERO);
    let cones = (0..tiles)
        .map(|t| Cone::around(dirs[t * TILE_TEXELS..((t + 1) * TILE_TEXELS).min(dirs.len())].iter().copied()))
        .collect();
    Packed { blocks, cones }
}

/// For one chunk of normals: for every tile of `active` (in increasing order), each normal's
/// per-lane f32 tile sums added into its per-lane f64 accumulators; then the lanes summed in f64
/// into `out`.
fn sum_tiles(kernel: Kernel, packed: &Packed, active: &[usize], normals: &[[f32; 3]], out: &mut [[f64; 3]]) {
    let mut lanes: Vec<WideSums> = vec![[[0.0; WIDE]; 3]; normals.len()];
    for &t in active {
        let blocks = &packed.blocks[t * BLOCKS_PER_TILE..(t + 1) * BLOCKS_PER_TILE];
        kernel.accumulate_wide(blocks, normals, &mut lanes);
    }
    for (o, l) in out.iter_mut().zip(&lanes) {
        *o = wide_total(l);
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
    irradiance_exact_with(env, normals, Kernel::at(crate::cpu::level()), true)
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
        // The chunk's cone, of the normals' directions (the sign of n . d does not depend on
        // |n|); a zero or non-finite normal leaves the chunk without a cone, so nothing is culled.
        let cone =
            if cull { Cone::around(ns.iter().map(|n| unit(DVec3::from(*n)).unwrap_or(DVec3::NAN))) } else { None };
        let hidden = |t: usize| matches!((&cone, &packed.cones[t]), (Some(c), Some(tile)) if c.hides(tile));
        let active: Vec<usize> = (0..packed.cones.len()).filter(|&t| !hidden(t)).collect();
        let nf: Vec<[f32; 3]> = ns.iter().map(|n| n.map(|c| c as f32)).collect();
        sum_tiles(kernel, &packed, &active, &nf, acc);
    });
    out
}

/// The work of [`reference_sphere`] on `env` and `view`: `(evaluated, all)`, where `evaluated`
/// counts the (normal, texel lane) terms the kernels compute after zero texels are skipped and
/// tiles are culled (padding lanes included), and `all` is disc pixels x W x H, the terms of the
/// sum written out. For the benchmark's arithmetic floor.
pub fn reference_work(env: &Image, view: &SphereView) -> (u64, u64) {
    let normals: Vec<[f64; 3]> = disc_pixels_tiled(view).iter().map(|p| p.1).collect();
    let all = normals.len() as u64 * (env.width * env.height) as u64;
    let packed = pack(env);
    let evaluated = normals
        .chunks(NORMAL_CHUNK)
        .map(|ns| {
            let cone = Cone::around(ns.iter().map(|n| unit(DVec3::from(*n)).unwrap_or(DVec3::NAN)));
            let kept = (0..packed.cones.len())
                .filter(|&t| !matches!((&cone, &packed.cones[t]), (Some(c), Some(tile)) if c.hides(tile)))
                .count();
            (kept * TILE_TEXELS * ns.len()) as u64
        })
        .sum();
    (evaluated, all)
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
    use crate::geometry::latlong;
    use crate::maths::sampling::sequences::SplitMix64;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        DVec3::from(a).dot(DVec3::from(b))
    }

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
        crate::geometry::fibonacci_sphere(n)
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
        let plain = irradiance_exact_with(&env, &ns, Kernel::Scalar, false);
        assert!(same(&plain, &irradiance_exact_with(&env, &ns, Kernel::Scalar, true)));
        for level in crate::cpu::tested_levels() {
            let kernel = Kernel::at(level);
            assert!(same(&plain, &irradiance_exact_with(&env, &ns, kernel, true)), "{level}");
            assert!(same(&plain, &irradiance_exact_with(&env, &ns, kernel, false)), "{level}");
            // Odd and even counts: AVX-512 takes the normals in pairs (an odd count leaves one).
            for cut in 1..4 {
                let part = &ns[..ns.len() - cut];
                assert!(same(&plain[..part.len()], &irradiance_exact_with(&env, part, kernel, true)), "{level}");
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
    fn culling_skips_tiles() {
        // A map lit only near +Y and normals pointing down: everything is culled, result 0.
        let env = map(128, 64, |d| if d[1] > 0.9 { [1.0; 3] } else { [0.0; 3] });
        let normals = [[0.0, -1.0, 0.0], [0.05, -0.99, 0.0]];
        let e = irradiance_exact(&env, &normals);
        assert_eq!(e, vec![[0.0; 3]; 2]);
        let packed = pack(&env);
        let cone = Cone::around(normals.iter().map(|n| unit(DVec3::from(*n)).unwrap())).unwrap();
        assert!(!packed.cones.is_empty());
        assert!(packed.cones.iter().all(|t| t.is_some_and(|t| cone.hides(&t))));
        // Seen from above, nothing is culled.
        let up = Cone::around([DVec3::Y].into_iter()).unwrap();
        assert!(packed.cones.iter().all(|t| !t.is_some_and(|t| up.hides(&t))));
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
}
