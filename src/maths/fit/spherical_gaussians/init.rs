//! The fit's deterministic starting lobes: greedy matching pursuit on the residual.
//!
//! With `r = f` (the fit map) at first, lobe k is placed at the texel of largest positive
//! residual luminance (Rec. 709, the first in scan order on a tie) that lies farther than
//! `clamp(1 / sqrt(lambda_j), pi / H, 0.5 rad)` from every earlier lobe j (its width, at least
//! a fit texel so that a peak sharper than the cap is not taken twice, at most 0.5 rad so that
//! a broad lobe does not shut out the sphere), and given the sharpness of the grid
//! `MIN_SHARPNESS 2^j` (up to the fit map's own cap, `Target::point_cap`) that best explains
//! the residual alone: the largest gain `sum_c max(P_c, 0)^2 / S`, `P_c = sum_t w_t G_t r_tc`, `S = sum_t w_t G_t^2`,
//! with amplitude `max(P_c, 0) / S`; then `r -= a G`. Each lobe depends only on the ones before
//! it, so the first n lobes of an (n + 1)-lobe start are the n-lobe start, and the NNLS
//! amplitudes that follow give an initial E that never grows with n. When no texel is left
//! (a black map, or one the lobes already explain or shut out), the remaining axes are the
//! spherical Fibonacci set of n points, with the sharpness `ln 2 / (1 - cos s)` of its
//! spacing `s = sqrt(4 pi / n)`.
//!
//! `seed` (0: none) moves each axis placed on a texel, once its residual is subtracted, by a
//! pseudo-random tangent offset uniform in the disc of radius `0.25 / sqrt(lambda)` radians (a
//! quarter of the lobe's width), from SplitMix64 seeded with `seed`: another start of the same
//! quality, for checking that a fit does not hinge on it.

use glam::DVec3;

use super::{Target, MIN_SHARPNESS};
use crate::colour::rec709_luminance;
use crate::geometry::fibonacci_sphere;
use crate::maths::sampling::sequences::SplitMix64;
use crate::values::SgLobe;

/// The largest angle (rad) around a placed lobe where the pursuit places no other.
const MAX_EXCLUSION: f64 = 0.5;

/// The starting lobes (amplitudes from the pursuit; the fit then solves them by NNLS).
pub fn initial_lobes(t: &Target, n: usize, seed: u64) -> Vec<SgLobe> {
    let mut residual = t.value.clone();
    let mut rng = SplitMix64::new(seed);
    let mut lobes = Vec::with_capacity(n);
    while lobes.len() < n {
        let Some(mut lobe) = pursue(t, &mut residual, &lobes) else {
            let k = lobes.len();
            lobes.extend(fallback(t, n, k));
            break;
        };
        if seed != 0 {
            lobe.axis = jitter(lobe.axis.into(), lobe.sharpness, &mut rng).into();
        }
        lobes.push(lobe);
    }
    lobes
}

/// The sharpness grid `MIN_SHARPNESS 2^j`, up to the fit map's own cap.
fn grid(t: &Target) -> Vec<f64> {
    let mut grid = vec![MIN_SHARPNESS];
    while grid[grid.len() - 1] * 2.0 <= t.point_cap() {
        grid.push(grid[grid.len() - 1] * 2.0);
    }
    grid
}

/// One step of the pursuit: the lobe at the residual's peak outside every lobe of `taken`
/// (the module documentation), with `residual` reduced by it; `None` when no texel left
/// has a positive residual luminance.
pub(super) fn pursue(t: &Target, residual: &mut [[f64; 3]], taken: &[SgLobe]) -> Option<SgLobe> {
    let texel_angle = std::f64::consts::PI / t.height as f64;
    let near: Vec<(DVec3, f64)> = taken
        .iter()
        .map(|l| (DVec3::from(l.axis), (1.0 / l.sharpness.sqrt()).clamp(texel_angle, MAX_EXCLUSION).cos()))
        .collect();
    let mut peak: Option<(usize, f64)> = None;
    for (i, r) in residual.iter().enumerate() {
        let y = rec709_luminance(r.map(|v| v as f32));
        if y > 0.0 && peak.is_none_or(|(_, b)| y > b) && !near.iter().any(|(a, c)| a.dot(t.dirs[i]) >= *c) {
            peak = Some((i, y));
        }
    }
    let axis = t.dirs[peak?.0];
    let (sharpness, amplitude) = best_sharpness(t, residual, axis, &grid(t));
    let lobe = SgLobe { axis: axis.into(), sharpness, amplitude };
    for (r, d) in residual.iter_mut().zip(&t.dirs) {
        let g = lobe.kernel((*d).into());
        for c in 0..3 {
            r[c] -= amplitude[c] * g;
        }
    }
    Some(lobe)
}

/// The grid sharpness of largest gain for a lobe at `axis` on `residual`, and its amplitude.
fn best_sharpness(t: &Target, residual: &[[f64; 3]], axis: DVec3, grid: &[f64]) -> (f64, [f64; 3]) {
    // Per grid value: S and P_c, summed over fixed blocks in order (deterministic).
    let parts = t.blocks(|r| {
        let mut acc = vec![[0.0f64; 4]; grid.len()];
        for i in r {
            let cos = axis.dot(t.dirs[i]) - 1.0;
            let w = t.weight[i];
            for (a, l) in acc.iter_mut().zip(grid) {
                let g = (l * cos).exp();
                a[0] += w * g * g;
                for c in 0..3 {
                    a[1 + c] += w * g * residual[i][c];
                }
            }
        }
        acc
    });
    let mut best = (grid[0], [0.0; 3], f64::NEG_INFINITY);
    for (j, l) in grid.iter().enumerate() {
        let s: f64 = parts.iter().map(|p| p[j][0]).sum();
        let p: [f64; 3] = std::array::from_fn(|c| parts.iter().map(|q| q[j][1 + c]).sum::<f64>().max(0.0));
        let gain = if s > 0.0 { p.iter().map(|v| v * v).sum::<f64>() / s } else { 0.0 };
        if gain > best.2 {
            best = (*l, if s > 0.0 { p.map(|v| v / s) } else { [0.0; 3] }, gain);
        }
    }
    (best.0, best.1)
}

/// `axis` moved by a uniform tangent offset in the disc of radius `0.25 / sqrt(lambda)` rad.
fn jitter(axis: DVec3, sharpness: f64, rng: &mut SplitMix64) -> DVec3 {
    let (e1, e2) = axis.any_orthonormal_pair();
    let radius = 0.25 / sharpness.sqrt() * rng.next_f64().sqrt();
    let angle = 2.0 * std::f64::consts::PI * rng.next_f64();
    (axis + radius * (angle.cos() * e1 + angle.sin() * e2)).normalize()
}

/// Lobes `k..n` when no residual is positive: points `k..n` of the Fibonacci set, zero
/// amplitude.
fn fallback(t: &Target, n: usize, k: usize) -> Vec<SgLobe> {
    let spacing = (4.0 * std::f64::consts::PI / n as f64).sqrt().min(std::f64::consts::PI);
    let sharpness = (2f64.ln() / (1.0 - spacing.cos())).clamp(MIN_SHARPNESS, t.point_cap());
    fibonacci_sphere(n)[k..].iter().map(|&axis| SgLobe { axis, sharpness, amplitude: [0.0; 3] }).collect()
}
