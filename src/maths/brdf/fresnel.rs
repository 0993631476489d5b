//! Exact Fresnel reflectance of a smooth dielectric interface (unpolarised light split into its
//! s and p components), the Brewster and critical angles, and the `Curves` the Fresnel operator
//! plots.
//!
//! Sources: E. Hecht, *Optics*, 5th ed., ch. 4.6 (the Fresnel equations, Snell's law, Brewster's
//! angle, total internal reflection); pbrt-v4 `FrDielectric` (src/pbrt/util/scattering.h), whose
//! structure (Snell, total internal reflection test, amplitude ratios squared) is followed here.
//!
//! Conventions: `eta_i` is the refractive index on the side the light comes from, `eta_t` the one it
//! enters; `cos_i` is the cosine of the angle of incidence, measured from the normal, in [0, 1].

use crate::values::curves::Curves;

/// Fresnel reflectances `(R_s, R_p)` of a smooth interface from index `eta_i` to index `eta_t`
/// for incidence cosine `cos_i`.
///
/// Formulas (Hecht, *Optics*, eqs. 4.42-4.43 and 4.56-4.57; pbrt-v4 `FrDielectric`):
/// - Snell: `sin_t = (eta_i / eta_t) sin_i`, with `sin_i = sqrt(1 - cos_i^2)`;
///   `sin_t >= 1` is total internal reflection and gives `(1, 1)`.
/// - `r_s = (eta_i cos_i - eta_t cos_t) / (eta_i cos_i + eta_t cos_t)`,
///   `r_p = (eta_t cos_i - eta_i cos_t) / (eta_t cos_i + eta_i cos_t)`, `R = r^2`.
///   The unpolarised reflectance is `(R_s + R_p) / 2`.
///
/// Edge cases (all defined so the result is always in [0, 1] and never NaN):
/// - `cos_i` is clamped to [0, 1] (NaN is treated as 0, grazing incidence).
/// - `eta_i == eta_t`: there is no interface, so `(0, 0)` at every angle *including* exactly 90
///   degrees. (For any `eta_i != eta_t` the reflectance tends to 1 at grazing incidence, so the
///   value at 90 degrees is discontinuous in eta there; we choose the physical "no interface"
///   answer for equal indices.)
/// - Exactly 90 degrees (`cos_i = 0`) with different indices: `(1, 1)` (both amplitude ratios are
///   exactly -1, or the light is totally reflected when `eta_i > eta_t`).
/// - Indices whose ratio rounds so that `cos_t = 0` at grazing incidence (both denominators 0):
///   `(1, 1)`, the limit for any two different indices.
/// - A non-positive, NaN or infinite index is not a physical medium; such inputs (which callers
///   validate) return `(1, 1)`, a perfect mirror, rather than NaN.
/// - Tiny rounding excursions are clamped into [0, 1].
pub fn reflectance(cos_i: f64, eta_i: f64, eta_t: f64) -> (f64, f64) {
    let valid = |e: f64| e.is_finite() && e > 0.0;
    if !valid(eta_i) || !valid(eta_t) {
        return (1.0, 1.0);
    }
    if eta_i == eta_t {
        return (0.0, 0.0);
    }
    let cos_i = if cos_i.is_nan() { 0.0 } else { cos_i.clamp(0.0, 1.0) };
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    // Snell's law: sin_t = (eta_i / eta_t) sin_i.
    let ratio = eta_i / eta_t;
    let sin2_t = ratio * ratio * sin2_i;
    if sin2_t >= 1.0 {
        // Total internal reflection (Hecht 4.7).
        return (1.0, 1.0);
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();

    let den_s = eta_i * cos_i + eta_t * cos_t;
    let den_p = eta_t * cos_i + eta_i * cos_t;
    if !(den_s > 0.0) || !(den_p > 0.0) {
        // Only possible at grazing incidence with cos_t == 0: the limit is a perfect reflection.
        return (1.0, 1.0);
    }
    let r_s = (eta_i * cos_i - eta_t * cos_t) / den_s;
    let r_p = (eta_t * cos_i - eta_i * cos_t) / den_p;
    (unit(r_s * r_s), unit(r_p * r_p))
}

/// Unpolarised reflectance `R = (R_s + R_p) / 2` (Hecht, *Optics*, 4.6; pbrt-v4 `FrDielectric`).
pub fn reflectance_unpolarised(cos_i: f64, eta_i: f64, eta_t: f64) -> f64 {
    let (rs, rp) = reflectance(cos_i, eta_i, eta_t);
    unit(0.5 * (rs + rp))
}

/// Clamps into [0, 1]; NaN (never produced by `reflectance` for valid input) becomes 1.
#[inline]
fn unit(x: f64) -> f64 {
    if x.is_nan() {
        1.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// Brewster's angle in degrees, `atan(eta_t / eta_i)` (Hecht, *Optics*, eq. 4.62): the angle of
/// incidence where `R_p = 0`. Computed as `atan2(eta_t, eta_i)` so huge ratios cannot overflow.
pub fn brewster_deg(eta_i: f64, eta_t: f64) -> f64 {
    eta_t.atan2(eta_i).to_degrees()
}

/// Critical angle in degrees, `asin(eta_t / eta_i)` (Hecht, *Optics*, eq. 4.69), beyond which light
/// is totally internally reflected. Exists only when `eta_i > eta_t` (denser to rarer medium);
/// `None` otherwise.
pub fn critical_deg(eta_i: f64, eta_t: f64) -> Option<f64> {
    if eta_i > eta_t && eta_t > 0.0 && eta_i.is_finite() {
        Some((eta_t / eta_i).clamp(0.0, 1.0).asin().to_degrees())
    } else {
        None
    }
}

/// Cosine of an angle in degrees, exactly 0 at 90 degrees (`cos(pi/2)` in floating point is 6e-17)
/// and exactly 1 at 0.
#[inline]
fn cos_deg(deg: f64) -> f64 {
    if deg == 90.0 {
        0.0
    } else if deg == 0.0 {
        1.0
    } else {
        deg.to_radians().cos()
    }
}

/// Formats an index of refraction without trailing zeros (`1`, `1.5`, `1.333`).
fn fmt_eta(eta: f64) -> String {
    format!("{eta}")
}

/// Fresnel reflectance curves against the angle of incidence.
///
/// `steps` points (at least 2; smaller values are raised to 2) evenly cover 0..=90 degrees, both
/// ends included: angle_k = 90 k / (steps - 1). Series: `rs`, `rp` (see [`reflectance`]) and
/// `r = (rs + rp) / 2`. Scalars: `eta_i`, `eta_t`, `brewster_deg` ([`brewster_deg`]) and
/// `critical_deg` ([`critical_deg`], `None` when there is no total internal reflection). Markers:
/// Brewster's angle always, the critical angle when it exists.
pub fn fresnel_curves(eta_i: f64, eta_t: f64, steps: usize) -> Curves {
    let steps = steps.max(2);
    let last = (steps - 1) as f64;
    let x: Vec<f64> = (0..steps).map(|k| if k == steps - 1 { 90.0 } else { 90.0 * k as f64 / last }).collect();
    let mut rs = Vec::with_capacity(steps);
    let mut rp = Vec::with_capacity(steps);
    let mut r = Vec::with_capacity(steps);
    for &deg in &x {
        let (s, p) = reflectance(cos_deg(deg), eta_i, eta_t);
        rs.push(s);
        rp.push(p);
        r.push(unit(0.5 * (s + p)));
    }
    let brewster = brewster_deg(eta_i, eta_t);
    let critical = critical_deg(eta_i, eta_t);
    let mut markers = vec![(format!("Brewster {brewster:.2}°"), brewster)];
    if let Some(c) = critical {
        markers.push((format!("critical {c:.2}°"), c));
    }
    Curves {
        title: format!("Fresnel reflectance, eta {} -> {}", fmt_eta(eta_i), fmt_eta(eta_t)),
        x_name: "angles_deg".to_string(),
        x_label: "angle of incidence (degrees)".to_string(),
        y_label: "reflectance".to_string(),
        x,
        series: vec![("rs".to_string(), rs), ("rp".to_string(), rp), ("r".to_string(), r)],
        scalars: vec![
            ("eta_i".to_string(), Some(eta_i)),
            ("eta_t".to_string(), Some(eta_t)),
            ("brewster_deg".to_string(), Some(brewster)),
            ("critical_deg".to_string(), critical),
        ],
        markers,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r_at(deg: f64, eta_i: f64, eta_t: f64) -> (f64, f64) {
        reflectance(cos_deg(deg), eta_i, eta_t)
    }

    #[test]
    fn normal_incidence_is_four_percent() {
        let (s, p) = reflectance(1.0, 1.0, 1.5);
        assert!((s - 0.04).abs() < 1e-15, "{s}");
        assert!((p - 0.04).abs() < 1e-15, "{p}");
        // Same from the other side at normal incidence.
        let (s, p) = reflectance(1.0, 1.5, 1.0);
        assert!((s - 0.04).abs() < 1e-15 && (p - 0.04).abs() < 1e-15);
    }

    #[test]
    fn brewster_angle() {
        let b = brewster_deg(1.0, 1.5);
        assert!((b - 56.3099).abs() < 1e-4, "{b}");
        let (s, p) = r_at(b, 1.0, 1.5);
        assert!(p < 1e-15, "{p}");
        assert!((s - 0.147929).abs() < 1e-6, "{s}");
        assert!((0.5 * (s + p) - 0.073964).abs() < 1e-6);
    }

    #[test]
    fn critical_angle_and_total_internal_reflection() {
        let c = critical_deg(1.5, 1.0).unwrap();
        assert!((c - 41.8103).abs() < 1e-4, "{c}");
        assert!(critical_deg(1.0, 1.5).is_none());
        assert!(critical_deg(1.5, 1.5).is_none());
        for k in 1..=200 {
            let deg = c + (90.0 - c) * k as f64 / 200.0;
            assert_eq!(r_at(deg, 1.5, 1.0), (1.0, 1.0), "{deg}");
        }
        // Just below the critical angle the reflectance is below 1.
        let (s, p) = r_at(c - 0.5, 1.5, 1.0);
        assert!(s < 1.0 && p < 1.0);
    }

    #[test]
    fn reflectance_at_85_degrees() {
        let (s, p) = r_at(85.0, 1.0, 1.5);
        let r = 0.5 * (s + p);
        assert!((r - 0.6128).abs() < 1e-4, "{r}");
    }

    /// Energy conservation through the independent transmission amplitudes (Hecht 4.44, 4.45):
    /// t_s = 2 eta_i cos_i / (eta_i cos_i + eta_t cos_t), t_p = 2 eta_i cos_i / (eta_t cos_i +
    /// eta_i cos_t), T = (eta_t cos_t) / (eta_i cos_i) t^2; R + T = 1 for each polarisation.
    #[test]
    fn energy_conservation_with_transmittance() {
        for &(ei, et) in &[(1.0, 1.5), (1.5, 1.0), (1.0, 2.4), (1.33, 1.0), (1.0, 1.000001)] {
            let crit = critical_deg(ei, et).unwrap_or(90.0);
            for k in 0..400 {
                let deg = crit * k as f64 / 400.0;
                let ci = cos_deg(deg);
                let si2 = 1.0 - ci * ci;
                let ct = (1.0 - (ei / et) * (ei / et) * si2).sqrt();
                let ts = 2.0 * ei * ci / (ei * ci + et * ct);
                let tp = 2.0 * ei * ci / (et * ci + ei * ct);
                let factor = (et * ct) / (ei * ci);
                let (rs, rp) = reflectance(ci, ei, et);
                assert!((rs + factor * ts * ts - 1.0).abs() < 1e-12, "s {ei}->{et} {deg}");
                assert!((rp + factor * tp * tp - 1.0).abs() < 1e-12, "p {ei}->{et} {deg}");
            }
        }
    }

    #[test]
    fn exactly_grazing() {
        assert_eq!(reflectance(0.0, 1.0, 1.5), (1.0, 1.0));
        assert_eq!(reflectance(0.0, 1.5, 1.0), (1.0, 1.0));
        assert_eq!(reflectance(0.0, 1.0, 1.000001), (1.0, 1.0));
        assert_eq!(reflectance(0.0, 1.0, 1e6), (1.0, 1.0));
        // Neighbouring doubles: the ratio may round to 1, cos_t to 0; still no NaN.
        let e = 1.5f64;
        let (s, p) = reflectance(0.0, e, f64::from_bits(e.to_bits() + 1));
        assert!(s == 1.0 && p == 1.0, "{s} {p}");
    }

    #[test]
    fn equal_indices_have_no_reflection() {
        for k in 0..=90 {
            assert_eq!(r_at(k as f64, 1.5, 1.5), (0.0, 0.0));
        }
        assert_eq!(reflectance(0.0, 1.0, 1.0), (0.0, 0.0));
        assert!(critical_deg(1.0, 1.0).is_none());
        assert!((brewster_deg(1.0, 1.0) - 45.0).abs() < 1e-12);
    }

    #[test]
    fn eta_near_one_is_tiny_and_finite() {
        for k in 0..=900 {
            let deg = k as f64 / 10.0;
            let (s, p) = r_at(deg, 1.0, 1.000001);
            assert!(s.is_finite() && p.is_finite());
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&p));
            if deg < 80.0 {
                assert!(s < 1e-9 && p < 1e-9, "{deg} {s} {p}");
            }
        }
        // Normal incidence: ((1 - n) / (1 + n))^2 ~ 2.5e-13.
        let (s, _) = reflectance(1.0, 1.0, 1.000001);
        assert!((s - 2.4999975e-13).abs() < 1e-18, "{s}");
    }

    #[test]
    fn huge_eta_is_a_mirror() {
        for k in 0..=90 {
            let (s, p) = r_at(k as f64, 1.0, 1e6);
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&p), "{k} {s} {p}");
            assert!(s > 0.99999, "{k} {s}");
            if k < 89 {
                assert!(p > 0.999, "{k} {p}");
            }
        }
        let (s, p) = r_at(45.0, 1e6, 1.0);
        assert_eq!((s, p), (1.0, 1.0));
    }

    #[test]
    fn outputs_in_unit_interval_never_nan() {
        let etas = [1e-6, 0.5, 0.999999, 1.0, 1.000001, 1.33, 1.5, 2.4, 1e6];
        for &ei in &etas {
            for &et in &etas {
                for k in 0..=1000 {
                    let c = k as f64 / 1000.0;
                    let (s, p) = reflectance(c, ei, et);
                    assert!((0.0..=1.0).contains(&s), "{c} {ei} {et} {s}");
                    assert!((0.0..=1.0).contains(&p), "{c} {ei} {et} {p}");
                }
            }
        }
        for &bad in &[f64::NAN, -1.0, 2.0] {
            let (s, p) = reflectance(bad, 1.0, 1.5);
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&p));
        }
        assert_eq!(reflectance(0.5, 0.0, 1.5), (1.0, 1.0));
        assert_eq!(reflectance(0.5, 1.0, f64::NAN), (1.0, 1.0));
    }

    #[test]
    fn curves_layout() {
        let c = fresnel_curves(1.0, 1.5, 91);
        assert_eq!(c.x.len(), 91);
        assert_eq!(c.x[0], 0.0);
        assert_eq!(*c.x.last().unwrap(), 90.0);
        assert!((c.x[45] - 45.0).abs() < 1e-12);
        let names: Vec<&str> = c.series.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["rs", "rp", "r"]);
        assert_eq!(c.x_name, "angles_deg");
        assert_eq!(c.title, "Fresnel reflectance, eta 1 -> 1.5");
        assert!((c.series[2].1[0] - 0.04).abs() < 1e-15);
        assert_eq!(c.series[2].1[90], 1.0);
        assert_eq!(c.scalars[3], ("critical_deg".to_string(), None));
        assert_eq!(c.markers.len(), 1);
        assert_eq!(c.markers[0].0, "Brewster 56.31°");

        let back = fresnel_curves(1.5, 1.0, 2);
        assert_eq!(back.x, vec![0.0, 90.0]);
        assert_eq!(back.markers.len(), 2);
        assert_eq!(back.markers[1].0, "critical 41.81°");
        assert!(back.scalars[3].1.is_some());
        assert_eq!(fresnel_curves(1.0, 1.5, 0).x.len(), 2);
    }
}
