//! `PrefilterSpecular(env, size, levels, samples, brdf: Ggx, sequence: Sobol, exact: false)`: the
//! specular prefiltered chain of split-sum image-based lighting (Karis 2013), a `mip chain` of cube
//! maps: level k has face size max(1, size >> k) and perceptual roughness k / (levels - 1),
//! alpha = roughness^2; level 0 (roughness 0) is the environment resampled to `size`.
//!
//! Each texel of level k > 0, with `n = v = r` its direction, is
//! `int L(l) D(h) (n.l)+ dl / int D(h) (n.l)+ dl` (GGX D, weighted by n.l as Filament and Karis
//! do; never clamped). `exact: false` estimates it with `samples` GGX samples of the `sequence`
//! and filtered importance sampling (Krivanek and Colbert 2008: each sample reads the source's
//! mip pyramid at `lod = 0.5 log2(Omega_s / Omega_p) + 1`, `Omega_s = 1 / (N pdf)`, `Omega_p` the
//! solid angle of the level-0 texel in the sample's direction); `exact: true` sums the same weighted lobe over every source
//! texel (the reference; O(6 size^2 x texels of the level) per level). Formulas in `maths::ggx`.
//! A constant environment gives 1 at every level and texel, both ways, to 1e-3 (tests), and the
//! error of the estimate against the reference falls as `samples` grows (tests).
//!
//! `env` is a lat-long image (resampled to a cube of face `size`, energy-preserving) or a cube map
//! (used as is when its face size is `size`, else resampled).

use crate::engine::fields::{AnyValue, Check, Input};
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::Value;
use crate::maths::ggx::{prefilter, LobeSequence};
use crate::values::ty::*;

crate::choice! {
    /// The specular lobe.
    pub enum SpecularBrdf {
        /// GGX (Trowbridge-Reitz) with n = v = r
        Ggx,
    }
}

crate::params! {
    pub struct PrefilterSpecularParams {
        /// the environment: a lat-long RGB map or a cube map
        #[input(&[IMAGE_T, CUBEMAP_T])]
        pub env: Input<AnyValue>,
        /// face size of level 0
        #[range(1, 4096)]
        pub size: usize = 128,
        /// number of levels; level k has roughness k / (levels - 1)
        #[range(1, 16)]
        pub levels: usize = 5,
        /// GGX samples per texel (exact: false)
        #[range(1, 1048576)]
        pub samples: usize = 1024,
        /// the lobe
        pub brdf: SpecularBrdf = SpecularBrdf::Ggx,
        /// the sample points: Sobol or Hammersley
        pub sequence: LobeSequence = LobeSequence::Sobol,
        /// true: sum over every source texel (the reference) instead of sampling
        pub exact: bool = false,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new(
        "PrefilterSpecular",
        "ibl",
        1,
        "GGX prefiltered cube-map chain (level k: roughness k/(levels-1)) by filtered importance sampling, or exactly",
    )
    .output("chain", OutputType::Fixed(MIP_CHAIN_T), "the chain; Save it with {level} in the path")
    .size(|_, p: PrefilterSpecularParams<Check>| Some((6 * p.size as u64, p.size as u64)))
    .code_hash(crate::op_code_hash!())
    .eval(eval)
}

fn eval(ctx: &mut OpContext, p: PrefilterSpecularParams) -> Result<Value, OpError> {
    let SpecularBrdf::Ggx = p.brdf;
    let src = super::env_cube(ctx, &p.env, p.size)?;
    Ok(Value::new(prefilter(&src, p.levels, p.samples, p.sequence, p.exact)))
}
