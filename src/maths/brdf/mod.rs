//! Lobes and Fresnel: evaluate, sample and pdf of the GGX, Charlie and modified Phong lobes, the
//! roughness each prefiltered level stands for, and exact dielectric Fresnel. Imports
//! [`super::sampling`] (the points lobes are sampled with) and nothing else of `maths`.

pub mod charlie;
pub mod fresnel;
pub mod ggx;
pub mod phong;
pub mod specular_lobe;
