//! The mathematics behind the operators, free of the engine: sequences, lobes, Fresnel,
//! relighting and its SIMD kernels, and statistical tests. The lat-long convention they all use
//! lives below them, in [`crate::geometry::latlong`].

/// Declares an enum whose variants pipeline files choose by name, with its name table: `NAMES`
/// (declaration order), `ALL`, `name()` and a case-insensitive `from_name()`. The engine's
/// `Choice` is implemented in `ops` (`crate::choice_by_name!`), where the engine is known.
/// Declared before the submodules, so it is in scope in each of them.
macro_rules! named_enum {
    ($(#[$meta:meta])* $vis:vis enum $name:ident { $($(#[$vmeta:meta])* $variant:ident),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        $vis enum $name { $($(#[$vmeta])* $variant),+ }

        impl $name {
            /// The names, in declaration order, as written in pipeline files.
            pub const NAMES: &'static [&'static str] = &[$(stringify!($variant)),+];
            pub const ALL: [$name; 0 $(+ { stringify!($variant); 1 })+] = [$($name::$variant),+];

            pub fn name(self) -> &'static str {
                Self::NAMES[self as usize]
            }

            /// The variant called `name` (case-insensitive, surrounding spaces ignored), or `None`.
            pub fn from_name(name: &str) -> Option<$name> {
                Self::ALL.iter().copied().find(|s| s.name().eq_ignore_ascii_case(name.trim()))
            }
        }
    };
}
pub mod chi_square;
pub mod error_metrics;
pub mod fresnel;
pub mod ggx;
pub mod glossy;
pub mod guide_table;
pub mod hierarchical_warp;
pub mod irradiance_cube;
pub mod kernels;
pub mod lights;
pub mod per_pixel;
pub mod phong;
pub mod reference;
pub mod relight;
pub mod resample;
pub mod rotation;
pub mod sequences;
pub mod sh;
pub mod statistics;
pub mod sun;

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
    use crate::data::{Distribution2D, Image};

    /// The sin(theta)-weighted distribution of a map's Rec. 709 luminance.
    pub fn luminance_distribution(env: &Image) -> Distribution2D {
        let lum: Vec<f32> = (0..env.height)
            .flat_map(|y| (0..env.width).map(move |x| (x, y)))
            .map(|(x, y)| {
                let [r, g, b] = env.rgb(x, y);
                0.2126 * r + 0.7152 * g + 0.0722 * b
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
