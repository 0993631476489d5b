//! Pearson's chi-square goodness-of-fit test, as used by pbrt's and Mitsuba's sampler tests:
//! histogram the samples of a warp, compare with the expected counts from its pdf.
//!
//! Sources:
//! - Cell pooling and the "expected 0 but observed" rejection follow Mitsuba 0.5's
//!   `ChiSquare::runTest` (src/libcore/chisquare.cpp, W. Jakob): cells sorted by expected count;
//!   cells below `min_expected` are pooled into one cell, and pooling continues past that point
//!   until the pooled cell's expected count reaches `min_expected`.
//! - The p-value is the chi-square survival function `P(X >= stat) = Q(dof/2, stat/2)`, with Q
//!   the regularised upper incomplete gamma function of the `statrs` crate
//!   (`statrs::function::gamma::checked_gamma_ur`: Cephes' series and continued fraction,
//!   relative tolerance 1e-15, over a Lanczos ln Gamma of about 16 digits).

/// The outcome of `chi_square_test`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChiSquareResult {
    /// Pearson's statistic `sum (O - E)^2 / E` over the cells after pooling.
    pub statistic: f64,
    /// Degrees of freedom: cells used (the pooled cell counting as one) minus 1.
    pub dof: usize,
    /// `Q(dof/2, statistic/2)`; 1.0 when `dof == 0` (nothing to test, Mitsuba's "ignore");
    /// 0.0 when any observation fell in a cell of expected count 0.
    pub p_value: f64,
    /// How many original cells went into the pooled cell.
    pub pooled_cells: usize,
    /// Cells with expected count 0 (or negative / NaN) but a positive observed count: the
    /// sampler produced something its pdf says is impossible. Any such cell fails the test.
    pub impossible_cells: usize,
    /// The total observed count in those cells.
    pub impossible_observations: f64,
}

impl ChiSquareResult {
    /// True when no observation was impossible and `p_value >= significance`.
    pub fn passed(&self, significance: f64) -> bool {
        self.impossible_cells == 0 && self.p_value >= significance
    }
}

/// Pearson's chi-square test of `observed` counts against `expected` counts (same length; both
/// non-negative; they should have the same total). Cells are visited in increasing order of
/// expected count; a cell with `E <= 0` and `O > 0` is counted as impossible; cells with
/// `0 < E < min_expected` are pooled (and pooling continues until the pool reaches
/// `min_expected`), all others contribute `(O - E)^2 / E`; the pool contributes
/// `(O_pool - E_pool)^2 / E_pool`. `dof = cells - 1` and `p = Q(dof/2, stat/2)`.
/// A usual `min_expected` is 5.
///
/// Panics if the slices differ in length (a test utility: a broken invariant).
pub fn chi_square_test(observed: &[f64], expected: &[f64], min_expected: f64) -> ChiSquareResult {
    assert_eq!(observed.len(), expected.len(), "chi_square_test: observed and expected differ in length");
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));

    let mut statistic = 0.0f64;
    let mut cells = 0usize;
    let mut pooled_obs = 0.0f64;
    let mut pooled_exp = 0.0f64;
    let mut pooled_cells = 0usize;
    let mut impossible_cells = 0usize;
    let mut impossible_observations = 0.0f64;

    for &i in &order {
        let (o, e) = (observed[i], expected[i]);
        if !(e > 0.0) {
            if o > 0.0 {
                impossible_cells += 1;
                impossible_observations += o;
            }
            continue;
        }
        if e < min_expected || (pooled_exp > 0.0 && pooled_exp < min_expected) {
            pooled_obs += o;
            pooled_exp += e;
            pooled_cells += 1;
        } else {
            let d = o - e;
            statistic += d * d / e;
            cells += 1;
        }
    }
    if pooled_exp > 0.0 {
        let d = pooled_obs - pooled_exp;
        statistic += d * d / pooled_exp;
        cells += 1;
    }
    let dof = cells.saturating_sub(1);
    let p_value = if impossible_cells > 0 {
        0.0
    } else if dof == 0 {
        1.0
    } else {
        chi_square_survival(statistic, dof as f64)
    };
    ChiSquareResult { statistic, dof, p_value, pooled_cells, impossible_cells, impossible_observations }
}

/// Chi-square survival function `P(X >= x)` for `k` degrees of freedom: `Q(k/2, x/2)`.
/// 1 for `x <= 0`, 0 for `x = inf`, NaN for `k <= 0`, `k = inf` or a NaN argument (the cases
/// that `statrs` refuses, given their limits here).
pub fn chi_square_survival(x: f64, k: f64) -> f64 {
    if !(k > 0.0) || k.is_infinite() || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    // Both arguments are now in (0, inf), where `checked_gamma_ur` is defined.
    statrs::function::gamma::checked_gamma_ur(0.5 * k, 0.5 * x).map_or(f64::NAN, |q| q.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-300)
    }

    #[test]
    fn survival_of_two_degrees_of_freedom_is_exp() {
        // k = 2: Q(1, x/2) = exp(-x/2).
        for &x in &[2e-6f64, 0.2, 1.0, 2.0, 4.0, 10.0, 20.0, 60.0, 200.0] {
            let q = chi_square_survival(x, 2.0);
            assert!(close(q, (-0.5 * x).exp(), 1e-12), "Q(1, {}) = {q}", 0.5 * x);
        }
        assert_eq!(chi_square_survival(0.0, 6.0), 1.0);
        assert_eq!(chi_square_survival(f64::INFINITY, 6.0), 0.0);
        assert!(chi_square_survival(2.0, 0.0).is_nan());
        assert!(chi_square_survival(f64::NAN, 6.0).is_nan());
    }

    #[test]
    fn chi_square_survival_known_values() {
        // Tables (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.4) and scipy.stats.chi2.sf:
        let p = chi_square_survival(10.0, 10.0);
        assert!((p - 0.440_493_285_065_212_3).abs() < 1e-9, "{p}");
        assert!((0.44..0.5).contains(&p));
        // dof 1: Q(1/2, x/2) = erfc(sqrt(x/2)); chi2 = 1 gives 0.3173105078629141.
        let p1 = chi_square_survival(1.0, 1.0);
        assert!((p1 - 0.317_310_507_862_914_04).abs() < 1e-10, "{p1}");
        // dof 2: exp(-x/2).
        assert!(close(chi_square_survival(7.0, 2.0), (-3.5f64).exp(), 1e-12));
        // 95% critical value for dof 10 is 18.307.
        assert!((chi_square_survival(18.307, 10.0) - 0.05).abs() < 1e-4);
        // Large dof: the series/continued-fraction switch must be seamless.
        let a = chi_square_survival(1000.0, 1000.0);
        assert!((0.49..0.51).contains(&a), "{a}");
    }

    #[test]
    fn perfect_fit_passes() {
        let e = vec![100.0; 20];
        let r = chi_square_test(&e, &e, 5.0);
        assert_eq!(r.statistic, 0.0);
        assert_eq!(r.dof, 19);
        assert!((r.p_value - 1.0).abs() < 1e-12);
        assert!(r.passed(1e-4));
    }

    #[test]
    fn gross_misfit_fails() {
        let e = vec![1000.0; 10];
        let mut o = e.clone();
        o[0] = 1300.0;
        o[1] = 700.0;
        let r = chi_square_test(&o, &e, 5.0);
        assert!((r.statistic - 180.0).abs() < 1e-9);
        assert!(r.p_value < 1e-20, "{}", r.p_value);
        assert!(!r.passed(1e-4));
    }

    #[test]
    fn small_cells_are_pooled() {
        // Ten cells of expected 1 pool into one of expected 10, plus two big cells.
        let mut e = vec![1.0; 10];
        e.push(50.0);
        e.push(40.0);
        let mut o = vec![0.0; 10];
        o[3] = 10.0;
        o.push(50.0);
        o.push(40.0);
        let r = chi_square_test(&o, &e, 5.0);
        assert_eq!(r.pooled_cells, 10);
        assert_eq!(r.dof, 2);
        assert_eq!(r.statistic, 0.0);
    }

    #[test]
    fn pooling_continues_until_enough() {
        // Expected 2 (pooled) then 4 and 100: the 4 joins the pool (2 < 5), the 100 does not.
        let e = [2.0, 4.0, 100.0];
        let o = [3.0, 3.0, 100.0];
        let r = chi_square_test(&o, &e, 5.0);
        assert_eq!(r.pooled_cells, 2);
        assert_eq!(r.dof, 1);
        assert!(r.statistic.abs() < 1e-12);
    }

    #[test]
    fn impossible_observations_are_flagged() {
        let e = [0.0, 50.0, 50.0];
        let o = [1.0, 49.0, 50.0];
        let r = chi_square_test(&o, &e, 5.0);
        assert_eq!(r.impossible_cells, 1);
        assert_eq!(r.impossible_observations, 1.0);
        assert_eq!(r.p_value, 0.0);
        assert!(!r.passed(1e-4));
        // Zero expected and zero observed is fine.
        let r = chi_square_test(&[0.0, 50.0, 50.0], &e, 5.0);
        assert_eq!(r.impossible_cells, 0);
        assert!(r.passed(1e-4));
    }
}
