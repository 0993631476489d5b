//! Geometry shared by every layer: the lat-long convention (and its per-size tables,
//! [`latlong_grid`]), the cube-map faces and their layouts in one image ([`cube_layout`]), the
//! azimuthal disc layouts ([`azimuthal`]: angular probe, sky angular, mirror ball), and the one
//! vector helper that glam does not provide with the rounding hdrflow's results were computed
//! with. A leaf module: it depends on nothing else in the crate but [`crate::choice`] (the
//! `choice!` macro, itself below every layer), so [`crate::values`] and [`crate::formats`] can use
//! it without depending on [`crate::maths`].

pub mod azimuthal;
pub mod cube_frame;
pub mod cube_layout;
pub mod cubemap;
pub mod latlong;
pub mod latlong_grid;
pub mod lens;
pub mod octahedral;
pub mod rotation;

use glam::DVec3;

/// `v / |v|`, or `None` when `|v|` is 0 or not finite.
///
/// A division per component, as hdrflow has always normalised. glam's `try_normalize` multiplies
/// by `1 / |v|` instead, which is as accurate (both within an ulp or so of the exact quotient)
/// but rounds differently: using it would move sphere normals by an ulp here and there and so
/// change rendered images bit-wise although the maths did not change.
#[inline]
pub fn unit(v: DVec3) -> Option<DVec3> {
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        Some(v / len)
    } else {
        None
    }
}

/// `n` unit directions spread evenly over the sphere: the spherical Fibonacci lattice
/// (Gonzalez 2010, "Measurement of areas on a sphere using Fibonacci and latitude-longitude
/// lattices"): point `k` at height `y = 1 - 2 (k + 1/2) / n` (equal-area bands, +Y first) and
/// azimuth `2 pi phi (k + 1/2)` (`phi` the golden ratio), so each holds about `4 pi / n` sr.
pub fn fibonacci_sphere(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (1.0 + 5f64.sqrt());
    (0..n)
        .map(|k| {
            let i = k as f64 + 0.5;
            let y = 1.0 - 2.0 * i / n as f64;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i;
            [r * phi.cos(), y, r * phi.sin()]
        })
        .collect()
}
