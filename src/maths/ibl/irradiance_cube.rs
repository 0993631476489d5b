//! Diffuse irradiance cube maps: `E(n) / pi = (1 / pi) int L(l) max(n.l, 0) dl`, so that a
//! constant environment of radiance 1 gives 1 (the radiance a white Lambertian surface reflects).
//!
//! - **Exact**: the sum over every source texel (lat-long texels with hdrflow's midpoint solid
//!   angle, cube texels with their exact solid angle), normalised by the same quadrature of the
//!   cosine: `sum L_t (n.l_t)+ Omega_t / sum (n.l_t)+ Omega_t`. The denominator is pi to
//!   O(1/H^2); dividing by it instead of pi makes the white furnace exact to rounding, and is the
//!   quadrature the SH path's `L_00` also uses. O(output texels x source texels) work: the
//!   reference.
//! - **Sh**: Ramamoorthi and Hanrahan (2001): project onto real SH up to band `order`
//!   (`maths::ibl::sh`, World frame), scale band l by `w_l A_l / pi` (`A_l`: `sh::lambert_coefficient`)
//!   and evaluate at each output texel. Windows `w_l` (P.-P. Sloan, "Stupid Spherical Harmonics
//!   (SH) Tricks", GDC 2008, section "Windowing"), with `L = order`:
//!   `None` 1; `Hann` `(1 + cos(pi l / (L + 1))) / 2`; `Lanczos` `sinc(pi l / (L + 1))`;
//!   `Deringing` `1 / (1 + lambda l^2 (l + 1)^2)`, the window that minimises the squared
//!   Laplacian of the result for a given strength (Sloan 2008), with `lambda` the smallest
//!   strength that makes the reconstructed irradiance non-negative in every channel (P.-P. Sloan,
//!   "Deringing Spherical Harmonics", SIGGRAPH Asia 2017 Technical Briefs, whose criterion this
//!   is), found by bisection in log(lambda) over the output texels (see [`from_sh`] for outputs
//!   larger than 64 x 64 per face) and a fixed 32 x 32 per face set of directions. `lambda` is 0 when no ringing goes below zero. As lambda grows only
//!   band 0 survives, the mean radiance, which is non-negative for a non-negative map, so the
//!   search always ends (at most 1e12).

use crate::maths::resample::layouts::normalised;
use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{cubemap as cube, latlong};
use crate::maths::ibl::sh::{eval_sh_into, lambert_coefficient, project, sh_count, sh_index};
use crate::values::{Cubemap, Image, ShFrame};

crate::choice! {
    /// How the irradiance is computed.
    pub enum IrradianceMethod {
        /// the sum over every source texel (the reference)
        Exact,
        /// spherical harmonics up to `order`, windowed
        Sh,
    }
}

crate::choice! {
    /// The SH window.
    pub enum ShWindow {
        /// no window (w_l = 1)
        None,
        /// w_l = (1 + cos(pi l / (order + 1))) / 2
        Hann,
        /// w_l = sinc(pi l / (order + 1))
        Lanczos,
        /// w_l = 1 / (1 + lambda l^2 (l + 1)^2), the smallest lambda that makes the irradiance non-negative
        Deringing,
    }
}

/// An environment read texel by texel (direction, solid angle, RGB) without a per-texel list:
/// a lat-long map keeps one (sin, cos, solid angle) per row and one (sin, cos) per column, a
/// cube map one unit vector and solid angle per texel of one face (shared by the six), so the
/// exact sums need O(W + H) or O(S^2) memory beside the map.
pub enum Texels<'a> {
    LatLong { img: &'a Image, rows: Vec<(f64, f64, f64)>, cols: Vec<(f64, f64)> },
    Cube { cube: &'a Cubemap, face: Vec<(DVec3, f64)> },
}

impl<'a> Texels<'a> {
    pub fn from_latlong(img: &'a Image) -> Texels<'a> {
        let (w, h) = (img.width, img.height);
        let rows = (0..h)
            .map(|y| {
                let (s, c) = latlong::theta_of_row(y, h).sin_cos();
                (s, c, latlong::texel_solid_angle(y, w, h))
            })
            .collect();
        let cols = (0..w).map(|x| latlong::phi_of_column(x, w).sin_cos()).collect();
        Texels::LatLong { img, rows, cols }
    }

    pub fn from_cube(cube: &'a Cubemap) -> Texels<'a> {
        let s = cube.size;
        let omega = cube::face_solid_angles(s);
        let face = (0..s * s)
            .map(|t| {
                let v = DVec3::new(cube::centre(t % s, s), cube::centre(t / s, s), 1.0);
                (v / v.length(), omega[t])
            })
            .collect();
        Texels::Cube { cube, face }
    }

    /// `sum_t L_t w(d_t) Omega_t / sum_t w(d_t) Omega_t` over the texels t whose weight `w` is
    /// positive (black when none is): the normalised filters of the exact references.
    pub fn weighted_mean(&self, weight: impl Fn(DVec3) -> f64) -> [f32; 3] {
        let mut acc = [0.0f64; 3];
        let mut total = 0.0;
        self.for_each(|l, o, v| {
            let w = weight(l);
            if w > 0.0 {
                let wt = w * o;
                for k in 0..3 {
                    acc[k] += v[k] * wt;
                }
                total += wt;
            }
        });
        normalised(acc, total)
    }

    /// Calls `f(direction, solid angle, rgb)` for every texel, in storage order.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut(DVec3, f64, [f64; 3])) {
        match self {
            Texels::LatLong { img, rows, cols } => {
                for (y, &(st, ct, o)) in rows.iter().enumerate() {
                    let row = img.row(y);
                    let ch = img.channels;
                    for (x, &(sp, cp)) in cols.iter().enumerate() {
                        let p = &row[x * ch..(x + 1) * ch];
                        let v = if ch < 3 { [p[0]; 3] } else { [p[0], p[1], p[2]] };
                        f(DVec3::new(-st * sp, ct, st * cp), o, v.map(f64::from));
                    }
                }
            }
            Texels::Cube { cube, face } => {
                let n = face.len();
                for fi in 0..6 {
                    for (t, &(u, o)) in face.iter().enumerate() {
                        f(cube::orient(fi, u), o, cube.texel(fi * n + t).map(f64::from));
                    }
                }
            }
        }
    }
}

/// The exact irradiance / pi cube map of face size `size`: per texel the cosine-weighted mean
/// of the map over the hemisphere around its direction.
pub fn exact(src: &Texels, size: usize) -> Cubemap {
    // A cube's texels as arrays, summed in lanes (`maths::ibl::zonal_sum`); a lat-long map stays on
    // `weighted_mean`, which reads it in place (arrays of a 16k map's texels would take 7.5 GB).
    if let Texels::Cube { cube: c, .. } = src {
        let zonal = crate::maths::ibl::zonal_sum::ZonalSource::from_cube(c);
        return Cubemap::from_fn(size, |f, x, y| zonal.mean(cube::texel_direction(f, x, y, size), |c| c));
    }
    Cubemap::from_fn(size, |f, x, y| {
        let n = cube::texel_direction(f, x, y, size);
        src.weighted_mean(|l| n.dot(l))
    })
}

/// SH coefficients (World frame) of a cube map: `sum_t L_t Y_lm(d_t) Omega_t` (exact texel solid
/// angles).
pub fn project_cube(c: &Cubemap, order: usize) -> Vec<[f64; 3]> {
    let n = sh_count(order);
    let s = c.size;
    let omega = cube::face_solid_angles(s);
    // One partial sum per face row, added in storage order: the same bits for any thread count.
    (0..6 * s)
        .into_par_iter()
        .map(|row| {
            let (f, y) = (row / s, row % s);
            let mut basis = vec![0.0; n];
            let mut acc = vec![[0.0f64; 3]; n];
            for x in 0..s {
                let (d, o) = (cube::texel_direction(f, x, y, s), omega[y * s + x]);
                let v = c.texel((f * s + y) * s + x).map(f64::from);
                eval_sh_into(ShFrame::World, order, d.into(), &mut basis);
                for (a, &yi) in acc.iter_mut().zip(&basis) {
                    for k in 0..3 {
                        a[k] += v[k] * yi * o;
                    }
                }
            }
            acc
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold(vec![[0.0f64; 3]; n], |mut sum, a| {
            for (si, ai) in sum.iter_mut().zip(a) {
                for k in 0..3 {
                    si[k] += ai[k];
                }
            }
            sum
        })
}

/// SH coefficients of a lat-long map in the World frame (`maths::ibl::sh::project`).
pub fn project_latlong(img: &Image, order: usize) -> Vec<[f64; 3]> {
    project(img, order, ShFrame::World)
}

/// The window `w_l` for l = 0..=order (`lambda` is used by `Deringing` only).
pub fn window(kind: ShWindow, order: usize, lambda: f64) -> Vec<f64> {
    let n = (order + 1) as f64;
    (0..=order)
        .map(|l| {
            let x = PI * l as f64 / n;
            match kind {
                ShWindow::None => 1.0,
                ShWindow::Hann => 0.5 * (1.0 + x.cos()),
                ShWindow::Lanczos => {
                    if l == 0 {
                        1.0
                    } else {
                        x.sin() / x
                    }
                }
                ShWindow::Deringing => {
                    let ll = (l * (l + 1)) as f64;
                    1.0 / (1.0 + lambda * ll * ll)
                }
            }
        })
        .collect()
}

/// Per direction, per band, the RGB sum `sum_m L_lm Y_lm(d)` (so a window is a dot product).
pub struct BandSums {
    order: usize,
    /// directions x (order + 1) x 3
    sums: Vec<f64>,
}

impl BandSums {
    pub fn new(coeffs: &[[f64; 3]], order: usize, dirs: &[DVec3]) -> BandSums {
        let nb = order + 1;
        let mut sums = vec![0.0; dirs.len() * nb * 3];
        sums.par_chunks_mut(nb * 3).zip(dirs.par_iter()).for_each(|(out, &d)| {
            let mut y = vec![0.0; sh_count(order)];
            eval_sh_into(ShFrame::World, order, d.into(), &mut y);
            for l in 0..=order {
                for m in -(l as isize)..=(l as isize) {
                    let i = sh_index(l, m);
                    for k in 0..3 {
                        out[3 * l + k] += coeffs[i][k] * y[i];
                    }
                }
            }
        });
        BandSums { order, sums }
    }

    /// The irradiance / pi at direction `i` with band weights `w`.
    #[inline]
    pub fn eval(&self, i: usize, w: &[f64]) -> [f64; 3] {
        let nb = self.order + 1;
        let s = &self.sums[i * nb * 3..(i + 1) * nb * 3];
        let mut out = [0.0; 3];
        for l in 0..nb {
            let f = w[l] * lambert_coefficient(l) / PI;
            for k in 0..3 {
                out[k] += f * s[3 * l + k];
            }
        }
        out
    }

    /// The smallest value of any channel over every direction.
    pub fn min(&self, w: &[f64]) -> f64 {
        let n = self.sums.len() / (3 * (self.order + 1));
        (0..n)
            .into_par_iter()
            .map(|i| self.eval(i, w).into_iter().fold(f64::INFINITY, f64::min))
            .reduce(|| f64::INFINITY, f64::min)
    }
}

/// The directions of every texel centre of a cube map of face size `size`, in storage order.
pub fn cube_directions(size: usize) -> Vec<DVec3> {
    (0..6 * size * size)
        .map(|t| {
            let (f, y, x) = (t / (size * size), (t / size) % size, t % size);
            cube::texel_direction(f, x, y, size)
        })
        .collect()
}

/// What the SH path reports.
#[derive(Clone, Debug, PartialEq)]
pub struct ShReport {
    /// The window strength: lambda for `Deringing`, 1 for `Hann` and `Lanczos`, 0 for `None`.
    pub strength: f64,
    /// The smallest channel value of the irradiance / pi without a window, over the check set.
    pub min_unwindowed: f64,
    /// The same with the window.
    pub min_windowed: f64,
}

/// The face size of the output directions that join the fixed check set (larger outputs are
/// checked after evaluation, see [`from_sh`]).
const CHECK_SIZE: usize = 64;

/// The SH irradiance / pi cube map of face size `size` from coefficients (World frame).
///
/// The window strength and the minima are found on a check set: the texel directions of a cube
/// of face min(size, 64) and of a 32 cube (at most 30,720 directions, so memory stays below
/// 25 MB at order 32 whatever `size`). The output is then evaluated texel by texel; with
/// `Deringing`, output texels that still come out negative (possible between check directions
/// when size > 64) join the check set and the strength is searched again (at most 4 times), and
/// the reported minima include every output texel.
pub fn from_sh(coeffs: &[[f64; 3]], order: usize, kind: ShWindow, size: usize) -> (Cubemap, ShReport) {
    let mut dirs = cube_directions(size.min(CHECK_SIZE));
    dirs.extend(cube_directions(32));
    let out_dirs = cube_directions(size);
    let none = window(ShWindow::None, order, 0.0);
    let mut rounds = 0;
    loop {
        let bands = BandSums::new(coeffs, order, &dirs);
        let min_unwindowed = bands.min(&none);
        let strength = match kind {
            ShWindow::None => 0.0,
            ShWindow::Hann | ShWindow::Lanczos => 1.0,
            ShWindow::Deringing => deringing_strength(&bands, order, min_unwindowed),
        };
        let w = window(kind, order, strength);
        let mut out = Cubemap::new(size);
        let mins: Vec<(f64, f64)> = out
            .data
            .par_chunks_mut(3)
            .zip(out_dirs.par_iter())
            .map(|(px, &d)| {
                let one = BandSums::new(coeffs, order, &[d]);
                let v = one.eval(0, &w);
                for k in 0..3 {
                    px[k] = v[k] as f32;
                }
                let raw = one.eval(0, &none);
                (v.into_iter().fold(f64::INFINITY, f64::min), raw.into_iter().fold(f64::INFINITY, f64::min))
            })
            .collect();
        let negative: Vec<DVec3> = out_dirs.iter().zip(&mins).filter(|(_, m)| m.0 < 0.0).map(|(d, _)| *d).collect();
        if kind == ShWindow::Deringing && strength > 0.0 && !negative.is_empty() && rounds < 4 {
            dirs.extend(negative);
            rounds += 1;
            continue;
        }
        let min_windowed = mins.iter().fold(bands.min(&w), |m, x| m.min(x.0));
        let min_unwindowed = mins.iter().fold(min_unwindowed, |m, x| m.min(x.1));
        return (out, ShReport { strength, min_unwindowed, min_windowed });
    }
}

/// The smallest lambda with a non-negative result (bisection in log lambda, 60 steps).
fn deringing_strength(bands: &BandSums, order: usize, min_unwindowed: f64) -> f64 {
    if min_unwindowed >= 0.0 || order == 0 {
        return 0.0;
    }
    let ok = |lambda: f64| bands.min(&window(ShWindow::Deringing, order, lambda)) >= 0.0;
    let mut hi = 1e-8;
    while !ok(hi) {
        hi *= 10.0;
        if hi > 1e12 {
            return hi;
        }
    }
    let mut lo = hi / 10.0;
    if hi == 1e-8 {
        lo = 0.0;
    }
    for _ in 0..60 {
        let mid = if lo > 0.0 { (lo * hi).sqrt() } else { 0.5 * hi };
        if ok(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::builtin::builtin;

    /// The exact irradiance from a coarser cube (the bakes sum over their 256 cube halved to
    /// 64, as they summed over a 64 cube of the map before): on the sky, whose sun is a few
    /// texels of the 128 cube, the 64 source's RMS relative difference is 2.9e-3 (largest 3.3e-2,
    /// texels with the sun at their horizon); a 32 source's is 2.0e-2, too coarse for a sun.
    #[test]
    fn exact_from_a_coarse_cube_is_close() {
        use crate::maths::resample::latlong_cube::latlong_to_cube;
        use crate::maths::resample::layouts::{downsample, LatLongSource};
        let fine = latlong_to_cube(&LatLongSource::new(&builtin("sky").unwrap()), 128);
        let a = exact(&Texels::from_cube(&fine), 8);
        let b = exact(&Texels::from_cube(&downsample(&fine)), 8);
        let rel = a.data.iter().zip(&b.data).map(|(x, y)| ((x - y) / x).abs());
        let worst = rel.clone().fold(0.0f32, f32::max);
        let rms = (rel.map(|r| r * r).sum::<f32>() / a.data.len() as f32).sqrt();
        assert!(rms < 5e-3 && worst < 5e-2, "rms {rms}, largest {worst}");
    }

    #[test]
    fn white_furnace_both_methods() {
        let env = builtin("constant").unwrap();
        let ex = exact(&Texels::from_latlong(&env), 4);
        assert!(ex.data.iter().all(|&v| (v - 1.0).abs() < 1e-6));
        for kind in [ShWindow::None, ShWindow::Hann, ShWindow::Lanczos, ShWindow::Deringing] {
            let (c, _) = from_sh(&project_latlong(&env, 4), 4, kind, 4);
            assert!(c.data.iter().all(|&v| (v - 1.0).abs() < 1e-3), "{kind:?}");
        }
    }

    #[test]
    fn linear_map_matches_closed_form() {
        // L = a + b.d gives E / pi = a + (2/3) b.n exactly in bands 0 and 1.
        let env = builtin("linear").unwrap();
        let b = crate::formats::builtin::LINEAR_B;
        let (c, _) = from_sh(&project_latlong(&env, 2), 2, ShWindow::None, 3);
        let ex = exact(&Texels::from_latlong(&env), 3);
        for (i, n) in cube_directions(3).into_iter().enumerate() {
            let want = crate::formats::builtin::LINEAR_A + (2.0 / 3.0) * (b[0] * n.x + b[1] * n.y + b[2] * n.z);
            assert!((c.data[3 * i] as f64 - want).abs() < 2e-3, "sh {i}");
            assert!((ex.data[3 * i] as f64 - want).abs() < 2e-3, "exact {i}: {} vs {want}", ex.data[3 * i]);
        }
    }

    #[test]
    fn deringing_makes_the_sky_non_negative() {
        let env = builtin("sky").unwrap();
        let coeffs = project_latlong(&env, 6);
        let (_, r) = from_sh(&coeffs, 6, ShWindow::Deringing, 8);
        assert!(r.min_unwindowed < 0.0, "{r:?}");
        assert!(r.strength > 0.0 && r.min_windowed >= 0.0, "{r:?}");
        // A slightly weaker window rings below zero again: the strength is the smallest.
        let mut dirs = cube_directions(8);
        dirs.extend(cube_directions(32));
        let bands = BandSums::new(&coeffs, 6, &dirs);
        let weaker = window(ShWindow::Deringing, 6, r.strength * 0.9);
        assert!(bands.min(&weaker) < 0.0);
        // An output larger than the check set is still non-negative at every texel.
        let (big, r) = from_sh(&coeffs, 6, ShWindow::Deringing, 80);
        assert!(r.min_windowed >= 0.0 && big.data.iter().all(|&v| v >= 0.0), "{r:?}");
    }
}
