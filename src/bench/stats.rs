//! The benchmark's statistics: the mean over seeds with its 95% confidence interval (Student t)
//! and the least-squares convergence slope of log(error) against log(N).

/// The 0.975 quantile of Student's t with `df` degrees of freedom (the factor of a two-sided
/// 95% interval), from `statrs` (`StudentsT::inverse_cdf`, through the inverse regularised
/// incomplete beta function); NaN for 0.
pub fn t_975(df: usize) -> f64 {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    // Location 0 and scale 1 are valid, and so is any df >= 1: only df 0 is refused.
    StudentsT::new(0.0, 1.0, df as f64).map_or(f64::NAN, |t| t.inverse_cdf(0.975))
}

/// The mean of `values` and the half-width of its 95% confidence interval,
/// t(0.975, n - 1) s / sqrt(n) with s the sample standard deviation. One value: (value, NaN)
/// (no spread to estimate); none: (NaN, NaN).
pub fn mean_ci95(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n == 1 {
        return (mean, f64::NAN);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, t_975(n - 1) * (var / n as f64).sqrt())
}

/// A least-squares fit of log(error) = a + b log(N).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slope {
    /// The exponent b: the error goes as N^b.
    pub slope: f64,
    /// b's standard error, sqrt(residual variance / sum (x - mean x)^2), residual variance over
    /// n - 2 degrees of freedom.
    pub std_error: f64,
    pub intercept: f64,
    /// Points used.
    pub points: usize,
}

/// Fits log(error) = a + b log(count) by ordinary least squares over the (count, error) points
/// whose count and error are positive and finite; None with fewer than 3 such points or a
/// single distinct count.
pub fn fit_slope(points: &[(f64, f64)]) -> Option<Slope> {
    let xy: Vec<(f64, f64)> = points
        .iter()
        .filter(|(n, e)| n.is_finite() && e.is_finite() && *n > 0.0 && *e > 0.0)
        .map(|(n, e)| (n.ln(), e.ln()))
        .collect();
    let n = xy.len();
    if n < 3 {
        return None;
    }
    let mx = xy.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let my = xy.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let sxx: f64 = xy.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = xy.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let ssr: f64 = xy.iter().map(|p| (p.1 - intercept - slope * p.0).powi(2)).sum();
    let std_error = (ssr / (n - 2) as f64 / sxx).sqrt();
    Some(Slope { slope, std_error, intercept, points: n })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// P(|T| < t) for Student's t with `nu` degrees of freedom, in closed form (Abramowitz and
    /// Stegun 26.7.3 and 26.7.4), theta = atan(t / sqrt(nu)).
    fn t_two_sided(t: f64, nu: usize) -> f64 {
        let theta = (t / (nu as f64).sqrt()).atan();
        let (s, c) = theta.sin_cos();
        if nu % 2 == 1 {
            // (2/pi) [theta + sin(theta) (cos + 2/3 cos^3 + 2*4/(3*5) cos^5 + ... up to cos^(nu-2))]
            let mut sum = 0.0;
            if nu > 1 {
                let mut term = c;
                sum = term;
                let mut k = 3;
                while k < nu {
                    term *= (k - 1) as f64 / k as f64 * c * c;
                    sum += term;
                    k += 2;
                }
            }
            2.0 / std::f64::consts::PI * (theta + s * sum)
        } else {
            // sin(theta) [1 + 1/2 cos^2 + 1*3/(2*4) cos^4 + ... up to cos^(nu-2)]
            let mut term = 1.0;
            let mut sum = 1.0;
            let mut k = 2;
            while k < nu {
                term *= (k - 1) as f64 / k as f64 * c * c;
                sum += term;
                k += 2;
            }
            s * sum
        }
    }

    #[test]
    fn t_quantiles_match_known_values_and_the_distribution() {
        // The 4-decimal table this replaced (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.2), which
        // rounds to within 5e-5; beyond 30 it used the normal 1.96, which t only approaches.
        for (df, table) in [(1, 12.7062), (2, 4.3027), (7, 2.3646), (10, 2.2281), (30, 2.0423), (31, 2.0395)] {
            assert!((t_975(df) - table).abs() <= 5e-5, "df {df}: {} vs {table}", t_975(df));
        }
        assert!((t_975(1000) - 1.9623).abs() <= 5e-5, "{}", t_975(1000));
        assert!(t_975(0).is_nan());
        // Every quantile leaves 2.5% in each tail, far below the table's rounding.
        for df in 1..=60 {
            let p = t_two_sided(t_975(df), df);
            assert!((p - 0.95).abs() < 1e-9, "df {df}: P(|T| < {}) = {p}", t_975(df));
        }
        // The closed form itself: the Cauchy distribution (df 1) and a large df near the normal.
        assert!((t_two_sided(1.0, 1) - 0.5).abs() < 1e-12);
        assert!((t_two_sided(1.96, 2000) - 0.95).abs() < 2e-4);
    }

    #[test]
    fn mean_and_interval() {
        let (m, ci) = mean_ci95(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        assert_eq!(m, 4.5);
        // s^2 = 6, n = 8: t(0.975, 7) sqrt(6 / 8), t(0.975, 7) = 2.3646 to 4 decimals.
        assert!((ci - t_975(7) * 0.75f64.sqrt()).abs() < 1e-12, "{ci}");
        assert!((ci - 2.3646 * 0.75f64.sqrt()).abs() < 5e-5, "{ci}");
        assert_eq!(mean_ci95(&[3.0, 3.0, 3.0]), (3.0, 0.0));
        let (m, ci) = mean_ci95(&[2.5]);
        assert_eq!(m, 2.5);
        assert!(ci.is_nan());
        assert!(mean_ci95(&[]).0.is_nan());
    }

    #[test]
    fn slopes_of_exact_power_laws() {
        for b in [-0.5, -1.0, -0.75, 0.0] {
            let pts: Vec<(f64, f64)> =
                [16.0f64, 64.0, 256.0, 1024.0, 4096.0].iter().map(|&n| (n, 3.0 * n.powf(b))).collect();
            let s = fit_slope(&pts).unwrap();
            assert!((s.slope - b).abs() < 1e-12, "{b}: {s:?}");
            assert!(s.std_error < 1e-9, "{b}: {s:?}");
            assert!((s.intercept - 3f64.ln()).abs() < 1e-10);
            assert_eq!(s.points, 5);
        }
        // Zero, negative and NaN errors are left out; two points are not enough.
        let pts = [(16.0, 0.25), (64.0, 0.125), (256.0, 0.0), (1024.0, f64::NAN), (4096.0, 1.0 / 64.0)];
        let s = fit_slope(&pts).unwrap();
        assert!((s.slope + 0.5).abs() < 1e-12 && s.points == 3);
        assert_eq!(fit_slope(&pts[..2]), None);
        assert_eq!(fit_slope(&[(4.0, 1.0), (4.0, 2.0), (4.0, 3.0)]), None);
        // Noise about the line gives a positive standard error: residuals +-d, -+... over
        // log2-spaced x. Points (x, y) = (0, d), (1, -2d + b), (2, d + 2b) have slope b and
        // residuals d, -2d, d: SSR = 6 d^2, sxx = 2, se = sqrt(6 d^2 / 1 / 2).
        let d = 0.1f64;
        let e = std::f64::consts::E;
        let pts = [(1.0, d.exp()), (e, (-2.0 * d - 0.5).exp()), (e * e, (d - 1.0).exp())];
        let s = fit_slope(&pts).unwrap();
        assert!((s.slope + 0.5).abs() < 1e-12, "{s:?}");
        assert!((s.std_error - (3.0f64).sqrt() * d).abs() < 1e-12, "{s:?}");
    }
}
