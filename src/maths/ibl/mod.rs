//! Image-based lighting: specular prefiltering of cube maps (filtered importance sampling and its
//! exact reference), diffuse irradiance, the split-sum LUTs, spherical harmonics (ours and
//! Filament's), and the exact GGX sums an engine's render is compared with. Imports
//! [`super::brdf`], [`super::sampling`], [`super::resample`] and [`super::render`].

pub mod fis_group;
pub mod fis_kernel;
pub mod ggx_reference;
pub mod irradiance_cube;
pub mod luts;
pub mod prefilter;
pub mod sh;
pub mod sh_filament;
pub mod zonal_sum;
