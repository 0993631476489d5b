//! Geometry shared by every layer: the lat-long convention (and its per-size tables,
//! [`latlong_grid`]), the azimuthal disc layouts ([`azimuthal`]: angular probe, sky angular,
//! mirror ball), and the one vector helper that glam does not provide with the rounding
//! hdrflow's results were computed with. A leaf module: it depends on nothing else in the crate,
//! so [`crate::data`] and [`crate::formats`] can use it without depending on [`crate::maths`].

pub mod azimuthal;
pub mod cubemap;
pub mod latlong;
pub mod latlong_grid;
pub mod octahedral;

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
