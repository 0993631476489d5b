//! The mathematics behind the operators, free of the engine, by domain. Each folder says what it
//! holds and what it may import; the domains form no cycle (checked by
//! `scripts/module_cycles.py`), in this order from the bottom up:
//!
//! - [`stats`]: statistics, error metrics (the colour weights are `crate::colour`);
//! - [`sampling`]: point sequences, warps of a distribution, and the tests that samplers are right;
//! - [`brdf`]: lobes and Fresnel (evaluate, sample, pdf);
//! - [`resample`]: footprint means, rotations, projections between spherical layouts;
//! - [`render`]: the sphere renderers and their exact references;
//! - [`ibl`]: prefiltering, irradiance, split-sum tables, spherical harmonics;
//! - [`camera`]: camera views of a map and their footprints;
//! - [`fit`]: least squares and what is fitted with it (lights, suns, spherical Gaussians);
//! - [`capture`]: camera response, exposure merging and fusion, bracket alignment.
//!
//! Below them all: the data types ([`crate::values`]) and the geometry of directions, layouts,
//! lenses and rotations ([`crate::geometry`]).

pub mod brdf;
pub mod camera;
pub mod capture;
pub mod fit;
pub mod ibl;
pub mod render;
pub mod resample;
pub mod sampling;
pub mod stats;

/// Asks the processor to bring `value`'s cache line towards L1 (`prefetcht0`): a hint with no
/// effect on results. No-op off x86_64.
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch of a valid reference's address; it reads nothing architecturally.
    #[allow(unused_unsafe)]
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(value as *const T as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// Maps and distributions the unit tests of several modules build alike.
#[cfg(test)]
pub(crate) mod test_maps {
    use crate::values::{Distribution2D, Image};

    /// The sin(theta)-weighted distribution of a map's Rec. 709 luminance.
    pub fn luminance_distribution(env: &Image) -> Distribution2D {
        let lum: Vec<f32> = (0..env.height)
            .flat_map(|y| (0..env.width).map(move |x| (x, y)))
            .map(|(x, y)| {
                let ([r, g, b], [wr, wg, wb]) = (env.rgb(x, y), crate::colour::REC709_F32);
                wr * r + wg * g + wb * b
            })
            .collect();
        Distribution2D::build(&Image::from_vec(env.width, env.height, 1, lum), true, false).unwrap()
    }

    /// Each texel of `env` replicated k x k: the same piecewise-constant function, so its
    /// midpoint sum converges to the exact integral over texels (error / k^2).
    pub fn replicate(env: &Image, k: usize) -> Image {
        Image::from_fn_rgb(env.width * k, env.height * k, |x, y| env.rgb(x / k, y / k))
    }
}
