//! Small dense least squares: a Cholesky solver and exact non-negative least squares.
//!
//! [`nnls`] is the active-set algorithm of Lawson and Hanson (*Solving Least Squares Problems*,
//! 1974, chapter 23, algorithm NNLS) run on the normal equations, as Bro and de Jong's FNNLS
//! does ("A fast non-negativity-constrained least squares algorithm", J. Chemometrics 11,
//! 1997): it minimises `||A x - b||^2 = x^T Q x - 2 c^T x + b^T b` over `x >= 0` from
//! `Q = A^T A` and `c = A^T b` alone, so a tall problem (one row per texel) costs one pass to
//! form `Q` and `c`, and then only `n x n` work. It ends at the KKT point of this convex
//! problem: `w = c - Q x` is `<= tol` wherever `x = 0`, and the passive variables solve the
//! unconstrained problem on their own columns. The tests compare it with an exhaustive search
//! over every active set (the exact minimiser) on random problems, to 1e-9 relative.
//!
//! Written here rather than taken from the `nnls` crate: that port of the Fortran code works on
//! the tall matrix itself and panics on a round-off path its README mentions, and neither
//! suits an operator whose inputs are users' maps. Here round-off is handled as the
//! algorithm's robust variants do: a passive variable that falls to `<= 0` moves back to the
//! active set, and a column that would make `Q_PP` singular is not admitted.

/// `L` with `L L^T = a` for a symmetric `n x n` matrix `a` (row-major), or `None` when a pivot
/// is `<= 1e-13` times the largest diagonal entry (numerically singular, or not positive
/// definite).
pub fn cholesky(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let scale = (0..n).map(|i| a[i * n + i].abs()).fold(0.0f64, f64::max);
    if !(scale > 0.0) || !scale.is_finite() {
        return None;
    }
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= l[j * n + k] * l[j * n + k];
        }
        if !(d > 1e-13 * scale) {
            return None;
        }
        let d = d.sqrt();
        l[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k];
            }
            l[i * n + j] = s / d;
        }
    }
    Some(l)
}

/// Solves `L L^T x = b` given [`cholesky`]'s `L`.
pub fn cholesky_solve(l: &[f64], n: usize, b: &[f64]) -> Vec<f64> {
    let mut y = b.to_vec();
    for i in 0..n {
        for k in 0..i {
            y[i] -= l[i * n + k] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            y[i] -= l[k * n + i] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    y
}

/// The unconstrained minimiser over the variables `set` (the others held at 0): `Q_SS s = c_S`,
/// or `None` when `Q_SS` is numerically singular.
fn solve_on(q: &[f64], n: usize, c: &[f64], set: &[usize]) -> Option<Vec<f64>> {
    let m = set.len();
    let sub: Vec<f64> = set.iter().flat_map(|&i| set.iter().map(move |&j| q[i * n + j])).collect();
    let l = cholesky(&sub, m)?;
    let rhs: Vec<f64> = set.iter().map(|&i| c[i]).collect();
    Some(cholesky_solve(&l, m, &rhs))
}

/// `argmin_{x >= 0} x^T Q x - 2 c^T x` for a symmetric positive semi-definite `n x n` `Q`
/// (row-major): Lawson-Hanson's NNLS on the normal equations (see the module documentation).
/// Returns 0 when `c <= 0` everywhere; every entry is finite and `>= 0`.
pub fn nnls(q: &[f64], n: usize, c: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; n];
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(scale > 0.0) || !scale.is_finite() {
        return x;
    }
    // Dual feasibility slack: w_j <= tol counts as <= 0.
    let tol = 1e-12 * scale;
    let mut passive = vec![false; n];
    // Columns refused this round (their admission made Q_PP singular); cleared when x moves.
    let mut refused = vec![false; n];
    // Lawson-Hanson terminates in finitely many steps; the cap only guards against round-off
    // cycling, and any x it stops at is feasible.
    for _ in 0..(10 * n + 20) {
        let w: Vec<f64> = (0..n).map(|j| c[j] - (0..n).map(|k| q[j * n + k] * x[k]).sum::<f64>()).collect();
        let Some(j) = (0..n)
            .filter(|&j| !passive[j] && !refused[j] && w[j] > tol)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]).then(b.cmp(&a)))
        else {
            break;
        };
        passive[j] = true;
        let mut moved = false;
        let mut first = true;
        loop {
            let set: Vec<usize> = (0..n).filter(|&i| passive[i]).collect();
            let s = solve_on(q, n, c, &set);
            // On admission, the new variable must come out positive (it does in exact
            // arithmetic since w_j > 0); otherwise its column is numerically dependent on the
            // passive ones: refuse it, as Lawson-Hanson's test of the new diagonal does.
            let s = match s {
                Some(s) if !first || s[set.iter().position(|&i| i == j).unwrap_or(0)] > 0.0 => s,
                _ => {
                    passive[j] = false;
                    refused[j] = true;
                    break;
                }
            };
            first = false;
            moved = true;
            if s.iter().all(|&v| v > 0.0) {
                for (&i, &v) in set.iter().zip(&s) {
                    x[i] = v;
                }
                break;
            }
            // Step from x towards s as far as feasibility allows: alpha = min x_i / (x_i - s_i)
            // over s_i <= 0; the variable that limits it reaches 0 and leaves, with any other
            // that round-off took to 0 or below.
            let mut alpha = 1.0f64;
            let mut limit = set[0];
            for (&i, &v) in set.iter().zip(&s) {
                if v <= 0.0 {
                    let d = x[i] - v;
                    let t = if d > 0.0 { x[i] / d } else { 0.0 };
                    if t < alpha {
                        alpha = t;
                        limit = i;
                    }
                }
            }
            for (&i, &v) in set.iter().zip(&s) {
                x[i] += alpha * (v - x[i]);
                if i == limit || x[i] <= 0.0 {
                    x[i] = 0.0;
                    passive[i] = false;
                }
            }
        }
        if moved {
            refused.iter_mut().for_each(|r| *r = false);
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::sampling::sequences::SplitMix64;

    fn objective(q: &[f64], n: usize, c: &[f64], x: &[f64]) -> f64 {
        let qx: f64 = (0..n).map(|i| x[i] * (0..n).map(|k| q[i * n + k] * x[k]).sum::<f64>()).sum();
        qx - 2.0 * (0..n).map(|i| c[i] * x[i]).sum::<f64>()
    }

    /// The exact minimiser by brute force: for every subset S, the unconstrained solution on S
    /// when it is positive; the best of those (the optimum is one of them).
    fn exhaustive(q: &[f64], n: usize, c: &[f64]) -> f64 {
        let mut best = 0.0;
        for mask in 1u32..(1 << n) {
            let set: Vec<usize> = (0..n).filter(|&i| mask >> i & 1 == 1).collect();
            if let Some(s) = solve_on(q, n, c, &set) {
                if s.iter().all(|&v| v >= 0.0) {
                    let mut x = vec![0.0; n];
                    for (&i, &v) in set.iter().zip(&s) {
                        x[i] = v;
                    }
                    best = f64::min(best, objective(q, n, c, &x));
                }
            }
        }
        best
    }

    #[test]
    fn cholesky_solves_and_refuses_singular() {
        let a = [4.0, 2.0, 0.4, 2.0, 5.0, 1.0, 0.4, 1.0, 3.0];
        let l = cholesky(&a, 3).unwrap();
        let x = cholesky_solve(&l, 3, &[1.0, 2.0, 3.0]);
        for i in 0..3 {
            let ax: f64 = (0..3).map(|k| a[i * 3 + k] * x[k]).sum();
            assert!((ax - [1.0, 2.0, 3.0][i]).abs() < 1e-12);
        }
        assert!(cholesky(&[1.0, 1.0, 1.0, 1.0], 2).is_none());
        assert!(cholesky(&[0.0], 1).is_none());
    }

    #[test]
    fn matches_the_exhaustive_search() {
        let mut rng = SplitMix64::new(7);
        for trial in 0..300 {
            let n = 1 + trial % 7;
            let m = n + 3;
            // A tall A (some columns nearly parallel) and b; Q = A^T A, c = A^T b.
            let mut a: Vec<f64> = (0..m * n).map(|_| rng.next_f64() - 0.3).collect();
            if n > 2 && trial % 3 == 0 {
                for r in 0..m {
                    a[r * n + 1] = a[r * n] + 1e-6 * rng.next_f64();
                }
            }
            let b: Vec<f64> = (0..m).map(|_| 2.0 * rng.next_f64() - 1.0).collect();
            let q: Vec<f64> =
                (0..n * n).map(|ij| (0..m).map(|r| a[r * n + ij / n] * a[r * n + ij % n]).sum()).collect();
            let c: Vec<f64> = (0..n).map(|j| (0..m).map(|r| a[r * n + j] * b[r]).sum()).collect();
            let x = nnls(&q, n, &c);
            assert!(x.iter().all(|&v| v >= 0.0 && v.is_finite()), "{trial}: {x:?}");
            let got = objective(&q, n, &c, &x);
            let want = exhaustive(&q, n, &c);
            let scale = c.iter().map(|v| v * v).sum::<f64>().max(1e-300);
            assert!(got - want <= 1e-9 * scale, "{trial}: {got} vs {want}");
            // KKT: no active variable would decrease the objective.
            for j in 0..n {
                let w = c[j] - (0..n).map(|k| q[j * n + k] * x[k]).sum::<f64>();
                if x[j] == 0.0 {
                    assert!(w <= 1e-6 * scale.sqrt(), "{trial}: w[{j}] = {w}");
                }
            }
        }
    }

    #[test]
    fn degenerate_problems() {
        // Nothing to fit: all zero.
        assert_eq!(nnls(&[1.0, 0.0, 0.0, 1.0], 2, &[-1.0, 0.0]), vec![0.0, 0.0]);
        assert_eq!(nnls(&[0.0; 4], 2, &[0.0, 0.0]), vec![0.0, 0.0]);
        // Two identical columns: one carries the solution, the objective is the optimum.
        let x = nnls(&[1.0, 1.0, 1.0, 1.0], 2, &[2.0, 2.0]);
        assert!((x[0] + x[1] - 2.0).abs() < 1e-12 && x.iter().all(|&v| v >= 0.0), "{x:?}");
        // The unconstrained optimum is feasible: it is returned.
        let x = nnls(&[2.0, 0.0, 0.0, 4.0], 2, &[2.0, 2.0]);
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 0.5).abs() < 1e-15, "{x:?}");
    }
}
