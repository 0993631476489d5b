//! Closed forms of the fit and the renderer (see the parent module's documentation).

use glam::DVec3;

use super::*;
use crate::geometry::latlong::direction_deg;

fn lobe(theta: f64, phi: f64, sharpness: f64, amplitude: [f64; 3]) -> SgLobe {
    SgLobe { axis: direction_deg(theta, phi), sharpness, amplitude }
}

fn one(l: &SgLobe) -> SphericalGaussians {
    SphericalGaussians { lobes: vec![l.clone()] }
}

/// The angle between two unit vectors, accurate near 0 (atan2 of |a x b| and a . b).
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (a, b) = (DVec3::from(a), DVec3::from(b));
    a.cross(b).length().atan2(a.dot(b))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn rendered_integral_matches_the_closed_form() {
    // 2 pi a (1 - exp(-2 lambda)) / lambda against the midpoint sum of the rendered map, for
    // lobes from nearly constant to 2.3 texels wide (1 / sqrt(lambda) at 1024 x 512), one on
    // the pole and one on the seam. Bound: twice the grid's own excess over 4 pi,
    // pi^2 / (24 H^2) = 1.6e-6 (what a broad lobe sees; measured 1.6e-6 at lambda 0.05, 1e-7
    // at lambda 10, 5e-9 at lambda 5000).
    let bound = 2.0 * PI * PI / (24.0 * 512.0 * 512.0);
    for l in [
        lobe(90.0, 180.0, 0.05, [1.0, 2.0, 3.0]),
        lobe(0.0, 0.0, 1.0, [2.0, 1.0, 0.5]),
        lobe(60.0, 0.0, 10.0, [5.0, 5.0, 5.0]),
        lobe(120.0, 250.0, 300.0, [100.0, 50.0, 10.0]),
        lobe(45.0, 90.0, 5000.0, [1e4, 1e4, 1e4]),
    ] {
        let img = render(&one(&l), 1024, 512);
        let sum = crate::maths::resample::layouts::latlong_integral(&img);
        let want = l.integral();
        for c in 0..3 {
            let e = rel(sum[c], want[c]);
            assert!(e < bound, "lambda {}: {} vs {} ({e:.1e})", l.sharpness, sum[c], want[c]);
        }
    }
    // The closed form itself: 4 pi a in the limit, 2 pi a / lambda for a sharp lobe.
    let i = lobe(0.0, 0.0, 1e-12, [1.0; 3]).integral()[0];
    assert!(rel(i, 4.0 * PI) < 1e-11, "{i}");
    let i = lobe(0.0, 0.0, 1e4, [1.0; 3]).integral()[0];
    assert!(rel(i, 2.0 * PI / 1e4) < 1e-15, "{i}");
}

#[test]
fn one_lobe_is_recovered() {
    // A map that is exactly one lobe (to f32 rounding), fitted at its own resolution: measured
    // errors 1e-10 rad and 4e-9 relative after 32 to 36 rounds (the fit stops by itself).
    for truth in [
        lobe(60.0, 200.0, 30.0, [2.0, 1.0, 0.5]),
        lobe(10.0, 20.0, 200.0, [50.0, 60.0, 70.0]),
        lobe(100.0, 359.0, 2.0, [0.1, 0.2, 0.3]),
    ] {
        let env = render(&one(&truth), 256, 128);
        let f = fit(&env, 1, 60, 0);
        let got = &f.sg.lobes[0];
        let a = angle(got.axis, truth.axis);
        eprintln!(
            "lambda {}: axis {a:.1e} rad, sharpness {:.1e}, amplitude {:.1e}, rmse {:.1e}, {} rounds",
            truth.sharpness,
            rel(got.sharpness, truth.sharpness),
            rel(got.amplitude[0], truth.amplitude[0]),
            f.relative_rmse,
            f.iterations
        );
        assert!(a < 1e-7, "{truth:?}: axis off by {a:e} rad");
        assert!(rel(got.sharpness, truth.sharpness) < 1e-7, "{truth:?}: {got:?}");
        for c in 0..3 {
            assert!(rel(got.amplitude[c], truth.amplitude[c]) < 1e-7, "{truth:?}: {got:?}");
        }
        assert!(f.relative_rmse < 1e-7 && f.iterations < 60, "{} {}", f.relative_rmse, f.iterations);
        assert_eq!((f.fit_width, f.fit_height), (256, 128));
    }
}

#[test]
fn block_reduction_keeps_the_integral_exactly() {
    let env = crate::formats::builtin::builtin("sky").unwrap();
    let t = Target::new(&env);
    assert_eq!((t.width, t.height), (FIT_WIDTH, FIT_HEIGHT));
    let want = crate::maths::resample::layouts::latlong_integral(&env);
    for c in 0..3 {
        let got: f64 = t.value.iter().zip(&t.weight).map(|(v, w)| v[c] * w).sum();
        assert!(rel(got, want[c]) < 1e-12, "{got} vs {}", want[c]);
    }
    // A size that is no multiple: the footprint average (1e-3 on the sky's sun).
    let odd = crate::maths::resample::layouts::to_latlong(
        &crate::maths::resample::layouts::LatLongSource::new(&env),
        300,
        150,
    );
    let t = Target::new(&odd);
    let got: f64 = t.value.iter().zip(&t.weight).map(|(v, w)| v[0] * w).sum();
    assert!(rel(got, want[0]) < 2e-3, "{got} vs {}", want[0]);
}

#[test]
fn energy_never_increases_with_iterations_and_the_start_is_nested() {
    let truth = SphericalGaussians {
        lobes: vec![
            lobe(50.0, 40.0, 80.0, [20.0, 18.0, 15.0]),
            lobe(95.0, 200.0, 3.0, [0.5, 0.7, 1.0]),
            lobe(140.0, 300.0, 12.0, [1.0, 0.5, 0.2]),
        ],
    };
    let env = render(&truth, 128, 64);
    let mut last = f64::INFINITY;
    for it in 0..12 {
        let f = fit(&env, 2, it, 0);
        assert!(f.relative_rmse <= last, "{it}: {} after {last}", f.relative_rmse);
        assert!(f.iterations <= it);
        last = f.relative_rmse;
    }
    let t = Target::new(&env);
    let five = initial_lobes(&t, 5, 3);
    for n in 1..5 {
        assert_eq!(initial_lobes(&t, n, 3), five[..n], "{n}");
    }
}

#[test]
fn degenerate_maps_give_finite_lobes() {
    let (w, h) = (64, 32);
    let mut hot = Image::new(w, h, 3);
    hot.pixel_mut(40, 9).copy_from_slice(&[1e6, 5e5, 1e5]);
    let maps = [Image::new(w, h, 3), Image::from_fn_rgb(w, h, |_, _| [0.5, 1.0, 2.0]), hot];
    for (k, env) in maps.iter().enumerate() {
        for n in [1, 5] {
            let f = fit(env, n, 10, 1);
            assert_eq!(f.sg.lobes.len(), n);
            assert!(f.relative_rmse.is_finite() && f.relative_rmse <= 1.0, "{k}: {}", f.relative_rmse);
            for l in &f.sg.lobes {
                assert!((DVec3::from(l.axis).length() - 1.0).abs() < 1e-12, "{k}: {l:?}");
                assert!(l.sharpness >= MIN_SHARPNESS && l.sharpness <= 4.0 * (h as f64 / PI).powi(2), "{k}: {l:?}");
                assert!(l.amplitude.iter().all(|a| a.is_finite() && *a >= 0.0), "{k}: {l:?}");
            }
            let img = render(&f.sg, w, h);
            assert!(img.data.iter().all(|v| v.is_finite()), "{k}");
        }
    }
    // Black: nothing to fit, exactly.
    let f = fit(&maps[0], 3, 5, 0);
    assert_eq!(f.relative_rmse, 0.0);
    assert!(f.sg.lobes.iter().all(|l| l.amplitude == [0.0; 3]));
    // Constant: a broad lobe explains it to a few percent.
    let f = fit(&maps[1], 1, 30, 0);
    assert!(f.relative_rmse < 0.05, "{}", f.relative_rmse);
    // One hot texel: the first lobe is on it.
    let f = fit(&maps[2], 2, 10, 0);
    let a = angle(f.sg.lobes[0].axis, latlong::texel_direction(40, 9, w, h));
    assert!(a < PI / h as f64, "{a}");
}
