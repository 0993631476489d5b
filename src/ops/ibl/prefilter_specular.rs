//! `PrefilterSpecular(env, size, levels, samples, brdf: Ggx, sequence: Sobol, exact: false,
//! roughness_map: Linear, roughness_list: None)`: the specular prefiltered chain of split-sum
//! image-based lighting (Karis 2013), a `mip chain` of cube maps: level k has face size
//! max(1, size >> k) and the perceptual roughness `roughness_map` gives it (alpha =
//! roughness^2): `Linear` k / (levels - 1), read back by Bevy and the glTF viewers with
//! `lod = r (N - 1)`; `Filament` cmgen's `1 - sqrt(1 - k / (levels - 1))`, the inverse of
//! Filament's `lod = (N - 1) r (2 - r)`; `List` the `roughness_list` (one value in [0, 1] per
//! level). A GGX level of roughness 0 (level 0 by default) is the environment resampled to its size.
//!
//! `brdf: Charlie` filters with glTF-IBL-Sampler's sheen lobe instead of GGX (its `charlie`
//! chain; `maths::brdf::specular_lobe`), every level included: at low roughness its lobe reflects
//! almost nothing above the horizon and the level tends to black, as the sampler's level 0 is.
//!
//! Each texel of level k > 0, with `n = v = r` its direction, is
//! `int L(l) D(h) (n.l)+ dl / int D(h) (n.l)+ dl` (GGX D, weighted by n.l as Filament and Karis
//! do; never clamped). `exact: false` estimates it with `samples` GGX samples of the `sequence`
//! and filtered importance sampling (Krivanek and Colbert 2008: each sample reads the source's
//! mip pyramid at `lod = 0.5 log2(Omega_s / Omega_p) + 1`, `Omega_s = 1 / (N pdf)`, `Omega_p` the
//! solid angle of the level-0 texel in the sample's direction); `exact: true` sums the same weighted lobe over every source
//! texel (the reference; O(6 size^2 x texels of the level) per level). Formulas in `maths::brdf::ggx`.
//! `rough_exact: true` (GGX, sampled chains) sums the rough levels exactly too, each over the
//! coarsest level of the source's pyramid whose texels are at most alpha / 8 wide, where that is
//! at most 2^26 texel pairs (`maths::ibl::prefilter::exact_source_level`): no sampling error, and within
//! about 1e-3 of the sum over the finest level (`hdrflow bench --bake` measures both).
//! The sharp GGX levels of large chains (where 4 texels span at most alpha radians) are
//! estimated in 4 x 4 (or 2 x 2) groups of texels that share one set of reads, each texel
//! reweighting them to its own lobe (`maths::ibl::fis_group`; `prefilter::group_side`).
//! A constant environment gives 1 at every level and texel, both ways, to 1e-3 (tests), and the
//! error of the estimate against the reference falls as `samples` grows (tests).
//!
//! `env` is a lat-long image (resampled to a cube of face `size`, energy-preserving) or a cube map
//! (used as is when its face size is `size`, else resampled).

use crate::engine::fields::{AnyValue, Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::brdf::ggx::LobeSequence;
pub use crate::maths::brdf::specular_lobe::{RoughnessMap, SpecularBrdf};
use crate::maths::ibl::prefilter::prefilter_chain;
use crate::values::ty::*;

crate::params! {
    pub struct PrefilterSpecularParams {
        /// the environment: a lat-long RGB map or a cube map
        #[input(&[IMAGE_T, CUBEMAP_T])]
        pub env: Input<AnyValue>,
        /// face size of level 0
        #[range(1, 4096)]
        pub size: usize = 128,
        /// number of levels; level k has the roughness roughness_map gives it
        #[range(1, 16)]
        pub levels: usize = 5,
        /// lobe samples per texel (exact: false)
        #[range(1, 1048576)]
        pub samples: usize = 1024,
        /// the lobe: Ggx, or Charlie (glTF-IBL-Sampler's sheen chain)
        pub brdf: SpecularBrdf = SpecularBrdf::Ggx,
        /// the sample points: Sobol or Hammersley
        pub sequence: LobeSequence = LobeSequence::Sobol,
        /// true: sum over every source texel (the reference) instead of sampling
        pub exact: bool = false,
        /// roughness of level k of N: Linear k/(N-1) (Bevy, Khronos: lod = r (N-1)), Filament 1 - sqrt(1 - k/(N-1)) (cmgen: lod = (N-1) r (2-r)), List
        pub roughness_map: RoughnessMap = RoughnessMap::Linear,
        /// (roughness_map: List) the perceptual roughness of each level, one per level
        #[range(0.0, 1.0)]
        pub roughness_list: Option<Vec<f64>>,
        /// (Ggx, exact: false) sum a level exactly over the coarsest pyramid level with texels at most alpha/8 wide, where that is at most 2^26 texel pairs, instead of sampling it
        pub rough_exact: bool = true,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "PrefilterSpecular",
        3,
        "GGX (or Charlie) prefiltered cube-map chain, level k at the roughness roughness_map gives it, by filtered importance sampling, or exactly",
        eval,
    )
    .output("chain", MIP_CHAIN_T, "the chain; Save it with {level} in the path")
    .size(|_, p| Some((6 * p.size as u64, p.size as u64)))
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: PrefilterSpecularParams<Check>) -> Result<(), CheckProblem> {
    match (p.roughness_map, &p.roughness_list) {
        (RoughnessMap::List, None) => Err(CheckProblem::at(
            PrefilterSpecularParams::roughness_list,
            "roughness_map: List needs roughness_list, one roughness per level",
        )),
        (RoughnessMap::List, Some(list)) if list.len() != p.levels => Err(CheckProblem::at(
            PrefilterSpecularParams::roughness_list,
            format!("roughness_list has {} values for {} levels: give one per level", list.len(), p.levels),
        )),
        (RoughnessMap::List, Some(_)) => Ok(()),
        (map, Some(_)) => Err(CheckProblem::at(
            PrefilterSpecularParams::roughness_list,
            format!("roughness_list is read only with roughness_map: List (this node has {map})"),
        )),
        (_, None) => Ok(()),
    }
}

/// The perceptual roughness of every level (validation checked the list).
fn level_roughness(p: &PrefilterSpecularParams) -> Vec<f64> {
    let list = p.roughness_list.as_deref().unwrap_or(&[]);
    (0..p.levels).map(|k| p.roughness_map.roughness(k, p.levels, list)).collect()
}

fn eval(ctx: &mut OpContext, p: PrefilterSpecularParams) -> Result<Value, OpError> {
    let src = super::env_cube(ctx, &p.env, p.size)?;
    let roughness = level_roughness(&p);
    Ok(Value::new(prefilter_chain(&src, &roughness, p.samples, p.sequence, p.exact, p.brdf, p.rough_exact)))
}

#[cfg(test)]
mod tests {
    use crate::formats::builtin::builtin;
    use crate::maths::brdf::ggx::LobeSequence;
    use crate::maths::brdf::specular_lobe::{RoughnessMap, SpecularBrdf};
    use crate::maths::ibl::prefilter::prefilter_chain;
    use crate::maths::resample::layouts::{to_cube, LatLongSource};

    /// A constant map gives the constant at every level and texel, for every roughness map and
    /// both lobes (Charlie from roughness 0.5 on: below it almost no sample is above the
    /// horizon), sampled and exact.
    #[test]
    fn constant_map_gives_the_constant_at_every_level() {
        let env = builtin("constant").unwrap();
        let c = to_cube(&LatLongSource::new(&env), 8);
        for map in [RoughnessMap::Linear, RoughnessMap::Filament] {
            let r: Vec<f64> = (0..4).map(|k| map.roughness(k, 4, &[])).collect();
            for exact in [false, true] {
                let chain = prefilter_chain(&c, &r, 64, LobeSequence::Sobol, exact, SpecularBrdf::Ggx, true);
                assert_eq!(chain.roughness, r);
                for l in &chain.levels {
                    assert!(l.data.iter().all(|&v| (v - 1.0).abs() < 1e-3), "{map} exact {exact}");
                }
            }
        }
        for exact in [false, true] {
            let chain =
                prefilter_chain(&c, &[0.5, 0.75, 1.0], 1024, LobeSequence::Sobol, exact, SpecularBrdf::Charlie, true);
            for (k, l) in chain.levels.iter().enumerate() {
                assert!(l.data.iter().all(|&v| (v - 1.0).abs() < 1e-3), "Charlie level {k} exact {exact}");
            }
        }
        // An explicit list with a mirror level below the top: the source's pyramid at that size.
        let chain = prefilter_chain(&c, &[0.0, 0.0, 0.6], 64, LobeSequence::Sobol, false, SpecularBrdf::Ggx, true);
        assert_eq!(chain.levels[1].size, 4);
        assert!(chain.levels[1].data.iter().all(|&v| (v - 1.0).abs() < 1e-6));
    }

    /// The sampled Charlie chain approaches the exact one on a smooth map.
    #[test]
    fn charlie_sampled_matches_exact_on_a_smooth_map() {
        let env = builtin("linear").unwrap();
        let c = to_cube(&LatLongSource::new(&env), 16);
        let r = [0.6, 1.0];
        let fis = prefilter_chain(&c, &r, 4096, LobeSequence::Sobol, false, SpecularBrdf::Charlie, true);
        let ex = prefilter_chain(&c, &r, 1, LobeSequence::Sobol, true, SpecularBrdf::Charlie, true);
        for (k, (a, b)) in fis.levels.iter().zip(&ex.levels).enumerate() {
            let worst = a.data.iter().zip(&b.data).fold(0.0f64, |m, (x, y)| m.max((x - y).abs() as f64 / *y as f64));
            assert!(worst < 3e-2, "level {k}: {worst}");
        }
    }
}
