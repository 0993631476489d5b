//! The mathematics behind the operators, free of the engine: sequences, lobes, Fresnel,
//! relighting and its SIMD kernels, and statistical tests. The lat-long convention they all use
//! lives below them, in [`crate::geometry::latlong`].

pub mod area_resize;
pub mod bilinear;
pub mod camera;
pub mod camera_area;
pub mod camera_view;
pub mod charlie;
pub mod chi_square;
pub mod colour;
pub mod disc_image;
pub mod error_metrics;
pub mod fis_kernel;
pub mod fresnel;
pub mod ggx;
pub mod ggx_reference;
pub mod glossy;
pub mod guide_table;
pub mod hierarchical_warp;
pub mod irradiance_cube;
pub mod kernels;
pub mod latlong_cube;
pub mod least_squares;
pub mod lights;
pub mod luts;
pub mod mis;
pub mod per_pixel;
pub mod phong;
pub mod reference;
pub mod relight;
pub mod resample;
pub mod rotation;
pub(crate) mod row_kernels;
pub mod sequences;
pub mod sh;
pub mod sh_filament;
pub mod shared_relight;
pub mod specular_lobe;
pub mod spherical_gaussians;
pub mod statistics;
pub mod sun;
pub mod texel_samples;
pub mod zonal_sum;

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
                let ([r, g, b], [wr, wg, wb]) = (env.rgb(x, y), crate::maths::colour::REC709_F32);
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
