//! What a fit texel holds when the map was reduced to the fit size: the mean of the lobe over
//! the texel, not its value at the centre.
//!
//! A reduced fit texel (a block mean, or the footprint average of a size that is no multiple)
//! is the map's mean over the texel's solid angle. A block mean of a map whose texels are
//! themselves means is that exactly: the midpoint solid angle of a lat-long texel is its exact
//! one times `(dt / 2) / sin(dt / 2)`, the same for every row, so the block's weights are
//! proportional to the exact ones. Fitting point values of the lobes to such texels biases sharp
//! lobes low: one lobe stored as texel means at 1024 x 512 came back with sharpness and
//! amplitude -4.8e-3 off at lambda 100, -8.4e-3 at 300, -4.1e-2 at 1000 and -6.8e-2 at 3000
//! (issue 39). So the model term of a reduced texel is
//!
//! ```text
//! M_t(G) = int_texel G(d) dw / int_texel dw,   G(d) = exp(lambda (mu . d - 1))
//! ```
//!
//! by an `n x n` Gauss-Legendre rule in `theta x phi` over the texel, weighted by `sin theta`
//! (the solid angle) and normalised by the rule's own sum, so that a constant has mean 1
//! exactly. The order grows with `beta = lambda max(dt, dp)^2` (the lobe's curvature over one
//! texel): `n = 2` below `beta = 1e-3`, 3 below 0.1, 4 below 0.6, 5 below 2, 6 below 4, 8
//! below 8, else 10 (up to the fit's cap, `beta = 12`; 2.7e-10 up to 16). Against a
//! 30 x 30 rule on 20,000 random (lobe, texel) pairs of a 256 x 128 map (lambda from 0.01 to
//! 6640, axes within a few widths of the texel, poles included), and an 80 x 80 rule on 3,000
//! pairs with `beta` from 2 to 16, the largest error of each order in its range is 6e-8 of the
//! lobe's peak, 9e-8 with the texels that keep their point value (`tests::texel_means_are_accurate`
//! checks 1e-7 on its own pairs).
//!
//! A texel keeps the point value `G(d_t)` where it is as good: where `G < 1e-12` all over the
//! texel (its points are within `r = sqrt(dt^2 + dp^2) / 2` of its centre, so `G <= G_max =
//! exp(lambda (cos(gamma - r) - 1))` at the angle `gamma` from the axis), or where
//! `G_max (alpha^2 + alpha + beta) / 4 < 2e-8`, with `alpha = lambda max(dt, dp) min(1, sin
//! gamma + r)` the kernel's largest change in the exponent across the texel. The same 20,000
//! pairs bound the point value's error by `0.16 G_max (alpha^2 + alpha + beta)` (the linear
//! term is the `sin theta` weight's, at the poles). Most texels of a sharp lobe keep it.
//!
//! The Levenberg-Marquardt derivatives are the same means of the point derivatives (the mean
//! is linear): `M(G lambda (e1 . d))`, `M(G lambda (e2 . d))`, `M(G lambda (mu . d - 1))`. The
//! pursuit that places lobes (`init`) keeps point values: it only chooses where to start.

use glam::DVec3;

use crate::values::SgLobe;

/// Below this, a kernel is the same as its mean for the fit (see the module documentation).
const NEGLIGIBLE: f64 = 1e-12;
/// The largest difference (relative to the lobe's peak) between the point value and the mean
/// for which a texel keeps the point value.
const POINT_TOL: f64 = 2e-8;
/// `(beta limit, order)`: the order of a lobe is that of the first limit above its `beta`.
const ORDERS: [(f64, usize); 7] = [(1e-3, 2), (0.1, 3), (0.6, 4), (2.0, 5), (4.0, 6), (8.0, 8), (f64::INFINITY, 10)];
const MAX_ORDER: usize = 10;

/// A quadrature node along one axis of a texel: `sin` and `cos` of its angle, and its weight.
#[derive(Clone, Copy, Debug)]
struct Node {
    sin: f64,
    cos: f64,
    weight: f64,
}

/// The Gauss-Legendre nodes of every texel row and column of a `width x height` lat-long
/// map, for each order of [`ORDERS`].
pub(super) struct TexelMeans {
    width: usize,
    height: usize,
    /// `max(dt, dp)^2`: `beta = lambda spacing2`.
    spacing2: f64,
    /// The texel's corner radius `r`, its `cos` and `sin`.
    r: f64,
    cos_r: f64,
    sin_r: f64,
    /// `rows[o][y n + i]` for the order `n` of `ORDERS[o]`: theta nodes, weights
    /// `w_i sin theta_i / sum_i w_i sin theta_i`.
    rows: Vec<Vec<Node>>,
    /// `cols[o][x n + j]`: phi nodes, weights `w_j / 2` (summing to 1).
    cols: Vec<Vec<Node>>,
}

/// The Gauss-Legendre nodes and weights of order `n` on [-1, 1] (Newton's iteration on the
/// Legendre polynomial from the Chebyshev guess, as in Numerical Recipes' `gauleg`).
pub(super) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    (p0, p1) = (p1, ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / dp;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

impl TexelMeans {
    pub(super) fn new(width: usize, height: usize) -> TexelMeans {
        let (dt, dp) = (std::f64::consts::PI / height as f64, std::f64::consts::TAU / width as f64);
        let r = 0.5 * dt.hypot(dp);
        let mut rows = Vec::new();
        let mut cols = Vec::new();
        for (_, n) in ORDERS {
            let rule = gauss_legendre(n);
            let mut row = Vec::with_capacity(height * n);
            for y in 0..height {
                let centre = (y as f64 + 0.5) * dt;
                let nodes: Vec<Node> = rule
                    .iter()
                    .map(|&(x, w)| {
                        let (sin, cos) = (centre + 0.5 * dt * x).sin_cos();
                        Node { sin, cos, weight: w * sin }
                    })
                    .collect();
                let total: f64 = nodes.iter().map(|v| v.weight).sum();
                row.extend(nodes.into_iter().map(|v| Node { weight: v.weight / total, ..v }));
            }
            rows.push(row);
            let mut col = Vec::with_capacity(width * n);
            for x in 0..width {
                let centre = (x as f64 + 0.5) * dp;
                col.extend(rule.iter().map(|&(u, w)| {
                    let (sin, cos) = (centre + 0.5 * dp * u).sin_cos();
                    Node { sin, cos, weight: 0.5 * w }
                }));
            }
            cols.push(col);
        }
        TexelMeans { width, height, spacing2: dt.max(dp).powi(2), r, cos_r: r.cos(), sin_r: r.sin(), rows, cols }
    }

    /// The index in [`ORDERS`] of the rule for a lobe of sharpness `lambda`.
    fn order(&self, lambda: f64) -> usize {
        let beta = lambda * self.spacing2;
        ORDERS.iter().position(|&(limit, _)| beta < limit).unwrap_or(ORDERS.len() - 1)
    }

    /// Whether the texel whose centre has `mu . d = c` can keep the lobe's point value: `G <
    /// NEGLIGIBLE` all over it, or `G_max (alpha^2 + alpha + beta) / 4 < POINT_TOL` (the module
    /// documentation).
    #[inline]
    fn point_is_enough(&self, lambda: f64, c: f64) -> bool {
        // Without a square root first: mu . d <= c cos r + sin r within r of the centre.
        let ln_negligible = NEGLIGIBLE.ln();
        if lambda * (c * self.cos_r + self.sin_r - 1.0) < ln_negligible {
            return true;
        }
        // cos(gamma - r), the largest mu . d within r of the centre when gamma > r.
        let s = (1.0 - c * c).max(0.0).sqrt();
        let ln_max = if c < self.cos_r { lambda * (c * self.cos_r + s * self.sin_r - 1.0) } else { 0.0 };
        if ln_max < ln_negligible {
            return true;
        }
        let alpha = lambda * self.spacing2.sqrt() * (s + self.r).min(1.0);
        let bound = 0.25 * (alpha * alpha + alpha + lambda * self.spacing2);
        ln_max.exp() * bound < POINT_TOL
    }

    /// The nodes of texel `t` (row-major) for the rule `ORDERS[o]`.
    fn nodes(&self, t: usize, o: usize) -> (&[Node], &[Node]) {
        let (x, y, n) = (t % self.width, t / self.width, ORDERS[o].1);
        debug_assert!(y < self.height);
        (&self.rows[o][y * n..(y + 1) * n], &self.cols[o][x * n..(x + 1) * n])
    }

    /// `M_t(G)` for `lobe`, texel `t` whose centre direction is `d`.
    pub(super) fn kernel(&self, t: usize, d: DVec3, lobe: &SgLobe) -> f64 {
        let (mu, l) = (DVec3::from(lobe.axis), lobe.sharpness);
        let c = mu.dot(d);
        if self.point_is_enough(l, c) {
            return (l * (c - 1.0)).exp();
        }
        let (rows, cols) = self.nodes(t, self.order(l));
        let mut p = [0.0; MAX_ORDER];
        for (pj, node) in p.iter_mut().zip(cols) {
            *pj = node.cos * mu.z - node.sin * mu.x;
        }
        let mut sum = 0.0;
        for row in rows {
            // As in `kernel_and_slopes`, term for term, so that both give the same bits.
            let mut along = 0.0;
            for (node, pj) in cols.iter().zip(&p) {
                let m = row.cos * mu.y + row.sin * pj - 1.0;
                along += node.weight * (l * m).exp();
            }
            sum += row.weight * along;
        }
        sum
    }

    /// `M_t(G)` and the means of the derivatives' kernels `M_t(G lambda (e1 . d))`,
    /// `M_t(G lambda (e2 . d))`, `M_t(G lambda (mu . d - 1))`.
    pub(super) fn kernel_and_slopes(&self, t: usize, d: DVec3, lobe: &SgLobe, e1: DVec3, e2: DVec3) -> (f64, [f64; 3]) {
        let (mu, l) = (DVec3::from(lobe.axis), lobe.sharpness);
        let c = mu.dot(d);
        if self.point_is_enough(l, c) {
            let g = (l * (c - 1.0)).exp();
            let gl = g * l;
            return (g, [gl * e1.dot(d), gl * e2.dot(d), gl * (c - 1.0)]);
        }
        let (rows, cols) = self.nodes(t, self.order(l));
        // Per column node: the horizontal parts of mu . d, e1 . d, e2 . d (d = (-s sin p, cos t,
        // s cos p) with s = sin t).
        let mut h = [[0.0; 3]; MAX_ORDER];
        for (hj, node) in h.iter_mut().zip(cols) {
            *hj = [mu, e1, e2].map(|v| node.cos * v.z - node.sin * v.x);
        }
        let mut sum = [0.0; 4];
        for row in rows {
            let mut along = [0.0; 4];
            for (node, hj) in cols.iter().zip(&h) {
                let m = row.cos * mu.y + row.sin * hj[0] - 1.0;
                let g = node.weight * (l * m).exp();
                along[0] += g;
                along[1] += g * (row.cos * e1.y + row.sin * hj[1]);
                along[2] += g * (row.cos * e2.y + row.sin * hj[2]);
                along[3] += g * m;
            }
            for (s, a) in sum.iter_mut().zip(along) {
                *s += row.weight * a;
            }
        }
        (sum[0], [l * sum[1], l * sum[2], l * sum[3]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;
    use crate::maths::sampling::sequences::SplitMix64;

    #[test]
    fn gauss_legendre_integrates_polynomials_of_degree_2n_minus_1() {
        for n in 1..=8 {
            let rule = gauss_legendre(n);
            assert!((rule.iter().map(|r| r.1).sum::<f64>() - 2.0).abs() < 1e-14, "{n}");
            for k in 0..2 * n {
                let got: f64 = rule.iter().map(|&(x, w)| w * x.powi(k as i32)).sum();
                let want = if k % 2 == 0 { 2.0 / (k as f64 + 1.0) } else { 0.0 };
                assert!((got - want).abs() < 1e-14, "n {n}, x^{k}: {got} vs {want}");
            }
        }
    }

    /// The mean by a 40 x 40 Gauss-Legendre rule (1e-12 up to `beta = 16`).
    fn reference(lobe: &SgLobe, x: usize, y: usize, w: usize, h: usize) -> f64 {
        let (dt, dp) = (std::f64::consts::PI / h as f64, std::f64::consts::TAU / w as f64);
        let rule = gauss_legendre(40);
        let (mut sum, mut weight) = (0.0, 0.0);
        for &(u, wu) in &rule {
            let theta = (y as f64 + 0.5 + 0.5 * u) * dt;
            for &(v, wv) in &rule {
                let phi = (x as f64 + 0.5 + 0.5 * v) * dp;
                let ww = wu * wv * theta.sin();
                sum += ww * lobe.kernel(latlong::direction(theta, phi));
                weight += ww;
            }
        }
        sum / weight
    }

    /// Random lobes (lambda log-uniform in [0.01, 26,560], `beta` 16, beyond the cap of a
    /// reduced map)
    /// within a few widths of random texels of a 256 x 128 map, the two polar rows among them:
    /// the rule within 1e-7 of the peak, and `kernel_and_slopes` the same kernel.
    #[test]
    fn texel_means_are_accurate() {
        let (w, h) = (256, 128);
        let means = TexelMeans::new(w, h);
        let mut rng = SplitMix64::new(39);
        let mut worst = [0.0f64; ORDERS.len()];
        for k in 0..3000 {
            let lambda = 0.01 * (4.0 * 664_000f64).powf(rng.next_f64());
            let (x, y) = (
                (rng.next_f64() * w as f64) as usize,
                if k % 10 == 0 { (k / 10) % 2 * (h - 1) } else { (rng.next_f64() * h as f64) as usize },
            );
            let d = DVec3::from(latlong::texel_direction(x, y, w, h));
            let (e1, e2) = d.any_orthonormal_pair();
            let angle = rng.next_f64() * [0.3, 1.0, 3.0, 6.0][k % 4] / lambda.sqrt();
            let turn = std::f64::consts::TAU * rng.next_f64();
            let axis =
                (d * angle.min(3.0).cos() + (e1 * turn.cos() + e2 * turn.sin()) * angle.min(3.0).sin()).normalize();
            let lobe = SgLobe { axis: axis.into(), sharpness: lambda, amplitude: [1.0; 3] };
            let t = y * w + x;
            let got = means.kernel(t, d, &lobe);
            let o = means.order(lambda);
            let err = (got - reference(&lobe, x, y, w, h)).abs();
            worst[o] = worst[o].max(err);
            assert!(err < 1e-7, "lambda {lambda}, texel ({x}, {y}), order {}: {err:e}", ORDERS[o].1);
            let (g, slopes) = means.kernel_and_slopes(t, d, &lobe, e1, e2);
            assert_eq!(g.to_bits(), got.to_bits());
            assert!(slopes.iter().all(|s| s.is_finite()));
        }
        eprintln!("largest error by order {:?}: {:?}", ORDERS.map(|o| o.1), worst.map(|e| format!("{e:.1e}")));
    }

    /// The slopes are the derivatives of the mean: `d M / du` for `mu' = normalise(mu + u e1)`
    /// is `M(G lambda (e1 . d))` at u = 0, and `d M / d ln lambda` is `M(G lambda (mu . d - 1))`.
    #[test]
    fn slopes_are_the_derivatives_of_the_mean() {
        let (w, h) = (256, 128);
        let means = TexelMeans::new(w, h);
        for (lambda, (x, y), off) in [(3.0, (40, 30), 0.2), (300.0, (100, 64), 0.03), (3000.0, (7, 0), 0.01)] {
            let d = DVec3::from(latlong::texel_direction(x, y, w, h));
            let (e1, e2) = d.any_orthonormal_pair();
            let mu = (d + off * e1 + 0.5 * off * e2).normalize();
            let (f1, f2) = mu.any_orthonormal_pair();
            let lobe = |mu: DVec3, l: f64| SgLobe { axis: mu.into(), sharpness: l, amplitude: [1.0; 3] };
            let t = y * w + x;
            let (_, slopes) = means.kernel_and_slopes(t, d, &lobe(mu, lambda), f1, f2);
            let eps = 1e-6;
            let at = |mu: DVec3, l: f64| means.kernel(t, d, &lobe(mu, l));
            let du = (at((mu + eps * f1).normalize(), lambda) - at((mu - eps * f1).normalize(), lambda)) / (2.0 * eps);
            let dv = (at((mu + eps * f2).normalize(), lambda) - at((mu - eps * f2).normalize(), lambda)) / (2.0 * eps);
            let ds = (at(mu, lambda * eps.exp()) - at(mu, lambda * (-eps).exp())) / (2.0 * eps);
            for (got, want) in slopes.iter().zip([du, dv, ds]) {
                assert!((got - want).abs() < 1e-6 * want.abs().max(1.0), "lambda {lambda}: {got} vs {want}");
            }
        }
    }
}
