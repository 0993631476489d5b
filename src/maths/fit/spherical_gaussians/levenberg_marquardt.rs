//! The geometry step of the fit: one Levenberg-Marquardt step on every lobe's axis and
//! sharpness (see the parent module's documentation for the parameters and derivatives).
//!
//! The sharpness moves at a fixed lobe integral: a step `lambda -> lambda'` scales the
//! amplitude by `h(lambda') / h(lambda)`, `h(lambda) = lambda / (1 - exp(-2 lambda))`, so that
//! `2 pi a / h(lambda)` (the integral) is unchanged, and `dL/ds` carries the extra term
//! `a G d ln h / ds`. Narrowing a lobe towards a bright peak then concentrates its energy
//! instead of dimming it, which the NNLS step that follows would otherwise have to undo: on
//! `builtin:sky` (12 lobes, 30 rounds) the relative RMSE is 0.048 with it and 0.053 without.
//! An accepted step is then doubled while that keeps lowering E (0.049 without).

use glam::DVec3;

use super::{kernels, Target, ACTIVE, MIN_SHARPNESS};
use crate::maths::fit::least_squares::{cholesky, cholesky_solve};
use crate::values::SgLobe;

impl Target {
    /// The Gauss-Newton system `(J^T W J, J^T W r)` in the lobes' `(u, v, s)`: see the module
    /// documentation. `J^T W J = M (x) A`, with `M = sum_t w_t g g^T` over the channel-free
    /// `g_ki = G_k lambda_k (e1 . d, e2 . d, mu . d - 1)_i` and `A_kl = sum_c a_kc a_lc`.
    pub(super) fn normal_equations(&self, lobes: &[SgLobe], frames: &[(DVec3, DVec3)]) -> (Vec<f64>, Vec<f64>) {
        let n = lobes.len();
        let m = 3 * n;
        let parts = self.blocks(|r| {
            let mut hm = vec![0.0; m * m];
            let mut b = vec![0.0; m];
            let mut g = vec![0.0; n];
            let mut jac = vec![0.0; m];
            let mut active = Vec::with_capacity(n);
            // For a reduced map: the means of the derivatives' kernels (`texel_mean`).
            let mut slopes = vec![[0.0; 3]; n];
            for t in r {
                let d = self.dirs[t];
                match &self.means {
                    None => kernels(lobes, d, &mut g),
                    Some(m) => {
                        for (k, (lobe, (e1, e2))) in lobes.iter().zip(frames).enumerate() {
                            (g[k], slopes[k]) = m.kernel_and_slopes(t, d, lobe, *e1, *e2);
                        }
                    }
                }
                let mut res = self.value[t];
                for (lobe, gk) in lobes.iter().zip(&g) {
                    for (r, a) in res.iter_mut().zip(lobe.amplitude) {
                        *r -= a * gk;
                    }
                }
                active.clear();
                active.extend((0..n).filter(|&k| g[k] > ACTIVE));
                let w = self.weight[t];
                for &k in &active {
                    let (lobe, (e1, e2)) = (&lobes[k], frames[k]);
                    let l = lobe.sharpness;
                    if self.means.is_some() {
                        let [du, dv, ds] = slopes[k];
                        jac[3 * k..3 * k + 3].copy_from_slice(&[du, dv, ds + g[k] * energy_slope(l)]);
                    } else {
                        let gl = g[k] * l;
                        let mu = DVec3::from(lobe.axis);
                        let ds = g[k] * (l * (mu.dot(d) - 1.0) + energy_slope(l));
                        jac[3 * k..3 * k + 3].copy_from_slice(&[gl * e1.dot(d), gl * e2.dot(d), ds]);
                    }
                    let rho: f64 = (0..3).map(|c| res[c] * lobe.amplitude[c]).sum();
                    for i in 3 * k..3 * k + 3 {
                        b[i] += w * rho * jac[i];
                    }
                }
                for (ai, &k) in active.iter().enumerate() {
                    for &l in &active[ai..] {
                        for i in 3 * k..3 * k + 3 {
                            let wi = w * jac[i];
                            for j in 3 * l..3 * l + 3 {
                                hm[i * m + j] += wi * jac[j];
                            }
                        }
                    }
                }
            }
            (hm, b)
        });
        let (mut h, mut b) = (vec![0.0; m * m], vec![0.0; m]);
        for (ph, pb) in parts {
            h.iter_mut().zip(ph).for_each(|(a, v)| *a += v);
            b.iter_mut().zip(pb).for_each(|(a, v)| *a += v);
        }
        for i in 0..m {
            for j in i..m {
                let (k, l) = (i / 3, j / 3);
                let a: f64 = (0..3).map(|c| lobes[k].amplitude[c] * lobes[l].amplitude[c]).sum();
                // Blocks l >= k were summed in full, so (i, j >= i) always holds the sum.
                let v = h[i * m + j] * a;
                h[i * m + j] = v;
                h[j * m + i] = v;
            }
        }
        (h, b)
    }
}

/// `d ln h / d ln lambda` for `h(lambda) = lambda / (1 - exp(-2 lambda))`, the amplitude per
/// unit integral: `1 - 2 lambda / (exp(2 lambda) - 1)`, from 0 (broad) to 1 (sharp).
fn energy_slope(l: f64) -> f64 {
    if l > 1e-8 {
        1.0 - 2.0 * l / (2.0 * l).exp_m1()
    } else {
        l
    }
}

/// `h(lambda) = lambda / (1 - exp(-2 lambda))`: a lobe of sharpness lambda and integral `2 pi e`
/// has amplitude `e h(lambda)`.
fn amplitude_per_energy(l: f64) -> f64 {
    if l > 1e-12 {
        l / -(-2.0 * l).exp_m1()
    } else {
        0.5
    }
}

/// The lobes moved by the step `delta` (`(u, v, s)` per lobe), capped as documented.
fn apply_step(lobes: &[SgLobe], frames: &[(DVec3, DVec3)], delta: &[f64], max_sharpness: f64) -> Vec<SgLobe> {
    lobes
        .iter()
        .zip(frames)
        .enumerate()
        .map(|(k, (lobe, (e1, e2)))| {
            let (mut u, mut v, s) = (delta[3 * k], delta[3 * k + 1], delta[3 * k + 2].clamp(-2.0, 2.0));
            let len = u.hypot(v);
            if len > 0.5 {
                u *= 0.5 / len;
                v *= 0.5 / len;
            }
            let axis = (DVec3::from(lobe.axis) + u * *e1 + v * *e2).normalize();
            let sharpness = (lobe.sharpness * s.exp()).clamp(MIN_SHARPNESS, max_sharpness);
            let scale = amplitude_per_energy(sharpness) / amplitude_per_energy(lobe.sharpness);
            SgLobe { axis: axis.into(), sharpness, amplitude: lobe.amplitude.map(|a| a * scale) }
        })
        .collect()
}

/// One Levenberg-Marquardt step on the axes and sharpnesses: the moved lobes and their E when
/// some damping (starting at `*damping`) lowers E below `energy`, else `None`.
pub(super) fn lm_step(t: &Target, lobes: &[SgLobe], energy: f64, damping: &mut f64) -> Option<(Vec<SgLobe>, f64)> {
    let frames: Vec<(DVec3, DVec3)> = lobes.iter().map(|l| DVec3::from(l.axis).any_orthonormal_pair()).collect();
    let (h, b) = t.normal_equations(lobes, &frames);
    let m = b.len();
    let max_diag = (0..m).map(|i| h[i * m + i]).fold(0.0f64, f64::max);
    if !(max_diag > 0.0) || !max_diag.is_finite() {
        return None;
    }
    for _ in 0..8 {
        let mut a = h.clone();
        for i in 0..m {
            a[i * m + i] += *damping * h[i * m + i].max(1e-9 * max_diag);
        }
        if let Some(l) = cholesky(&a, m) {
            let delta = cholesky_solve(&l, m, &b);
            if delta.iter().all(|v| v.is_finite()) {
                let moved = apply_step(lobes, &frames, &delta, t.max_sharpness());
                let e = t.energy(&moved);
                if e < energy {
                    *damping = (*damping / 3.0).max(1e-12);
                    return Some(extend(t, lobes, &frames, &delta, (moved, e)));
                }
            }
        }
        *damping = (*damping * 4.0).min(1e12);
    }
    None
}

/// After an accepted step `delta`: the step doubled while that keeps lowering E (at most 6
/// times: x64), since a Gauss-Newton step on a lobe's width undershoots far from the optimum.
fn extend(
    t: &Target,
    lobes: &[SgLobe],
    frames: &[(DVec3, DVec3)],
    delta: &[f64],
    mut best: (Vec<SgLobe>, f64),
) -> (Vec<SgLobe>, f64) {
    let mut scale = 1.0;
    for _ in 0..6 {
        scale *= 2.0;
        let step: Vec<f64> = delta.iter().map(|v| v * scale).collect();
        let moved = apply_step(lobes, frames, &step, t.max_sharpness());
        let e = t.energy(&moved);
        if !(e < best.1) {
            break;
        }
        best = (moved, e);
    }
    best
}
