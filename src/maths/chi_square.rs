//! Pearson's chi-square goodness-of-fit test, as used by pbrt's and Mitsuba's sampler tests:
//! histogram the samples of a warp, compare with the expected counts from its pdf.
//!
//! Sources:
//! - Cell pooling and the "expected 0 but observed" rejection follow Mitsuba 0.5's
//!   `ChiSquare::runTest` (src/libcore/chisquare.cpp, W. Jakob): cells sorted by expected count;
//!   cells below `min_expected` are pooled into one cell, and pooling continues past that point
//!   until the pooled cell's expected count reaches `min_expected`.
//! - The p-value is the chi-square survival function `P(X >= stat) = Q(dof/2, stat/2)`, with Q
//!   the regularised upper incomplete gamma function computed as in W. H. Press et al.,
//!   *Numerical Recipes*, 3rd ed., section 6.2 (`gser`: series, `gcf`: continued fraction by
//!   the modified Lentz method).
//! - ln Gamma: Lanczos approximation, g = 7, n = 9 (coefficients of P. Godfrey, as tabulated in
//!   the Wikipedia article "Lanczos approximation"), about 1e-15 relative accuracy.

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
pub fn chi_square_survival(x: f64, k: f64) -> f64 {
    gamma_q(0.5 * k, 0.5 * x)
}

/// `ln Gamma(x)` for `x > 0` (Lanczos, g = 7, n = 9):
/// `Gamma(z + 1) = sqrt(2 pi) t^(z + 1/2) e^-t A_g(z)`, `t = z + g + 1/2`,
/// `A_g(z) = c_0 + sum_{k=1}^{8} c_k / (z + k)`; for `x < 1/2` the reflection formula
/// `ln Gamma(x) = ln(pi / sin(pi x)) - ln Gamma(1 - x)`. NaN for `x <= 0`.
#[allow(clippy::excessive_precision)]
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_93,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_13,
        -176.615_029_162_140_59,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_571_6e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if !(x > 0.0) {
        return f64::NAN;
    }
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let z = x - 1.0;
    let mut a = C[0];
    for (k, &c) in C.iter().enumerate().skip(1) {
        a += c / (z + k as f64);
    }
    let t = z + G + 0.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (z + 0.5) * t.ln() - t + a.ln()
}

/// Regularised lower incomplete gamma `P(a, x) = gamma(a, x) / Gamma(a)`, `a > 0`, `x >= 0`.
pub fn gamma_p(a: f64, x: f64) -> f64 {
    1.0 - gamma_q(a, x)
}

/// Regularised upper incomplete gamma `Q(a, x) = Gamma(a, x) / Gamma(a) = 1 - P(a, x)`
/// (Numerical Recipes 3rd ed., 6.2: the series for `x < a + 1`, the continued fraction
/// otherwise). `Q(a, 0) = 1`, `Q(a, inf) = 0`, NaN for `a <= 0` or NaN input.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if !(a > 0.0) || x.is_nan() || a.is_infinite() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    let q = if x < a + 1.0 { 1.0 - gamma_p_series(a, x) } else { gamma_q_continued_fraction(a, x) };
    q.clamp(0.0, 1.0)
}

/// `P(a, x)` by the series (NR 6.2.5):
/// `P(a, x) = e^-x x^a / Gamma(a) * sum_{n>=0} x^n / (a (a+1) ... (a+n))`.
fn gamma_p_series(a: f64, x: f64) -> f64 {
    let gln = ln_gamma(a);
    let mut ap = a;
    let mut del = 1.0 / a;
    let mut sum = del;
    for _ in 0..1_000_000 {
        ap += 1.0;
        del *= x / ap;
        sum += del;
        if del.abs() < sum.abs() * f64::EPSILON {
            break;
        }
    }
    (sum.ln() - x + a * x.ln() - gln).exp()
}

/// `Q(a, x)` by the continued fraction (NR 6.2.7), evaluated with the modified Lentz method:
/// `Q(a, x) = e^-x x^a / Gamma(a) * 1/(x+1-a- 1(1-a)/(x+3-a- 2(2-a)/(x+5-a- ...)))`.
fn gamma_q_continued_fraction(a: f64, x: f64) -> f64 {
    let fpmin = f64::MIN_POSITIVE / f64::EPSILON;
    let gln = ln_gamma(a);
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / fpmin;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..1_000_000u32 {
        let fi = i as f64;
        let an = -fi * (fi - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < fpmin {
            d = fpmin;
        }
        c = b + an / c;
        if c.abs() < fpmin {
            c = fpmin;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < f64::EPSILON {
            break;
        }
    }
    (-x + a * x.ln() - gln).exp() * h
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-300)
    }

    #[test]
    fn ln_gamma_known_values() {
        assert!(ln_gamma(1.0).abs() < 1e-14);
        assert!(ln_gamma(2.0).abs() < 1e-14);
        assert!(close(ln_gamma(10.0), 362_880.0f64.ln(), 1e-13));
        assert!(close(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln(), 1e-13));
        assert!(close(ln_gamma(0.1), 9.513_507_698_668_732f64.ln(), 1e-12));
        assert!(close(ln_gamma(100.0), 359.134_205_369_575_4, 1e-13));
    }

    #[test]
    fn q_of_one_is_exp() {
        for &x in &[1e-6f64, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 100.0] {
            let q = gamma_q(1.0, x);
            assert!(close(q, (-x).exp(), 1e-12), "Q(1, {x}) = {q}");
        }
        assert_eq!(gamma_q(3.0, 0.0), 1.0);
        assert_eq!(gamma_q(3.0, f64::INFINITY), 0.0);
        assert!(gamma_q(0.0, 1.0).is_nan());
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
