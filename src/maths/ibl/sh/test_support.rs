//! Test helpers shared by the SH files' tests: random directions and the small test maps.

use std::f64::consts::PI;

use crate::maths::render::reference::tests::map;
use crate::maths::sampling::sequences::SplitMix64;
use crate::values::Image;

pub(super) fn random_dir(rng: &mut SplitMix64) -> [f64; 3] {
    let z = 1.0 - 2.0 * rng.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * rng.next_f64();
    [r * phi.cos(), r * phi.sin(), z]
}

/// The built-in sky's gradient and ground without its sun, blended across the horizon over
/// +-0.1 in d_y (~6 degrees) so it is smooth.
pub(super) fn smooth_sky(w: usize, h: usize) -> Image {
    let zenith = [0.2, 0.35, 0.8];
    let horizon = [0.8, 0.85, 0.9];
    let ground = [0.14, 0.15, 0.08];
    map(w, h, move |d| {
        let t = d[1].max(0.0).sqrt();
        let sky = [0, 1, 2].map(|c| horizon[c] + (zenith[c] - horizon[c]) * t);
        let u = ((d[1] + 0.1) / 0.2).clamp(0.0, 1.0);
        let b = u * u * (3.0 - 2.0 * u); // smoothstep
        [0, 1, 2].map(|c| ground[c] + (sky[c] - ground[c]) * b)
    })
}

/// A smooth map with something in every band and no symmetry: a gradient and two lobes.
pub(super) fn lumpy(w: usize, h: usize) -> Image {
    let a = glam::DVec3::new(0.6, 0.5, -0.62).normalize();
    let b = glam::DVec3::new(-0.3, -0.2, 0.93).normalize();
    map(w, h, move |d| {
        let v = glam::DVec3::from(d);
        let lobe = |c: glam::DVec3, k: i32| v.dot(c).max(0.0).powi(k);
        let s = 1.0 + 0.3 * d[0] - 0.2 * d[1] + 0.1 * d[2] + 2.0 * lobe(a, 6) + 0.7 * lobe(b, 3);
        [s, 0.5 * s + 0.4 * lobe(b, 2), 2.0 - 0.5 * d[0] * d[2]]
    })
}

pub(super) fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|ch| (a[ch] - b[ch]).abs() <= tol)
}
