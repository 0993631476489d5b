//! `PlayCanvasEnvAtlas(chain, irradiance)`: PlayCanvas' environment atlas (`app.scene.envAtlas`)
//! as a 512 x 512 linear RGB image, laid out as its `EnvLighting.generateAtlas` lays it out
//! (`formats::playcanvas_atlas`: the rects, the seams, the half turn between its equirect and
//! hdrflow's); `Save(png_format: Rgbp)` writes it as the RGBP PNG PlayCanvas loads.
//!
//! - The six shiny mips: level 0 of `chain` (roughness 0, the map itself) averaged over each
//!   equirect texel's footprint (`maths::resample::layouts::to_latlong`, energy-preserving): the
//!   box mips PlayCanvas' one-sample reprojection of its mipmapped source gives.
//! - The six rough rects: levels 1..=6 of `chain`, which should hold roughness 2/11, 4/11, 6/11,
//!   8/11, 10/11 and 1 (PlayCanvas' specularPower 512 ... 1: `playcanvas_atlas::chain_roughness`;
//!   other roughness is a warning, the mistake tests/playcanvas_render.rs makes), read bilinearly, seamlessly across faces, at each texel's direction, as a GPU
//!   reads a cube level.
//! - The ambient rect: `irradiance` (a cube of E / pi, `IrradianceCubemap`), read the same way.
//!
//! Texels outside every rect are black, as in PlayCanvas' own atlas.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::formats::playcanvas_atlas::{self as atlas, Rect};
use crate::maths::resample::layouts::{to_latlong, CubeSource};
use crate::values::ty::*;
use crate::values::{Cubemap, Image, MipChain};

crate::params! {
    pub struct PlayCanvasEnvAtlasParams {
        /// the specular chain: 7 levels, of roughness 0, 2/11, 4/11, 6/11, 8/11, 10/11, 1 (PrefilterSpecular, roughness_map: List; other roughness: a warning)
        #[input(&[MIP_CHAIN_T])]
        pub chain: Input<MipChain>,
        /// the ambient: a cube map of E / pi (IrradianceCubemap)
        #[input(&[CUBEMAP_T])]
        pub irradiance: Input<Cubemap>,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "PlayCanvasEnvAtlas",
        2,
        "PlayCanvas' envAtlas (512 x 512): the chain and the irradiance as equirect rects with seams, as EnvLighting.generateAtlas lays them out",
        eval,
    )
    .output("image", IMAGE_T, "the atlas, linear RGB (Save it with png_format: Rgbp)")
    .size(|_, _| Some((atlas::SIZE as u64, atlas::SIZE as u64)))
    .into()
}

/// `rect` of `out` filled with `c` read bilinearly at each texel's direction.
fn fill_bilinear(out: &mut Image, rect: Rect, c: &Cubemap) {
    for j in 0..rect.h {
        for i in 0..rect.w {
            let v = c.bilinear(atlas::direction(rect, i, j)).map(|v| v as f32);
            out.pixel_mut(rect.x + i, rect.y + j)[..3].copy_from_slice(&v);
        }
    }
}

/// The atlas of `chain` (7 levels) and `irradiance` (module doc).
pub fn env_atlas(chain: &MipChain, irradiance: &Cubemap) -> Result<Image, String> {
    if chain.levels.len() != 7 {
        return Err(format!(
            "the chain has {} levels: PlayCanvas' atlas takes 7 (the map, then roughness {:?})",
            chain.levels.len(),
            &atlas::chain_roughness()[1..]
        ));
    }
    let mut out = Image::new(atlas::SIZE, atlas::SIZE, 3);
    let sharp = CubeSource::new(&chain.levels[0]);
    for rect in atlas::shiny_rects() {
        atlas::place(&mut out, rect, &to_latlong(&sharp, rect.w - 2, rect.h - 2));
    }
    for (rect, level) in atlas::rough_rects().into_iter().zip(&chain.levels[1..]) {
        fill_bilinear(&mut out, rect, level);
    }
    fill_bilinear(&mut out, atlas::AMBIENT, irradiance);
    Ok(out)
}

/// Whether `chain`'s levels hold the roughness PlayCanvas reads from the atlas' levels.
pub fn has_playcanvas_roughness(chain: &MipChain) -> bool {
    let want = atlas::chain_roughness();
    chain.roughness.len() == want.len() && chain.roughness.iter().zip(&want).all(|(a, b)| (a - b).abs() <= 1e-6)
}

fn eval(ctx: &mut OpContext, p: PlayCanvasEnvAtlasParams) -> Result<Value, OpError> {
    for c in p.chain.levels.iter().chain(std::iter::once(&*p.irradiance)) {
        super::check_cube_finite(c)?;
    }
    if !has_playcanvas_roughness(&p.chain) {
        ctx.warn(format!(
            "the chain's levels hold roughness {:?}, where PlayCanvas' shader reads {:?}: its spheres will show the wrong blur",
            p.chain.roughness,
            atlas::chain_roughness()
        ));
    }
    env_atlas(&p.chain, &p.irradiance).map(Value::new).map_err(OpError::Invalid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cubemap as cube;
    use glam::DVec3;

    /// A constant environment gives the constant in every rect, seams included, and black
    /// between them; a chain of other roughness is refused.
    #[test]
    fn a_constant_environment_fills_every_rect_with_it() {
        let cube = |v: f32, s: usize| Cubemap { size: s, data: vec![v; 6 * s * s * 3] };
        let levels: Vec<Cubemap> = (0..7).map(|k| cube(0.5, (64usize >> k).max(1))).collect();
        let chain = MipChain { levels, roughness: atlas::chain_roughness() };
        let img = env_atlas(&chain, &cube(0.25, 8)).unwrap();
        for r in atlas::shiny_rects().into_iter().chain(atlas::rough_rects()) {
            for (i, j) in [(0, 0), (r.w - 1, r.h - 1), (r.w / 2, r.h / 2)] {
                let p = img.pixel(r.x + i, r.y + j);
                assert!((p[0] - 0.5).abs() < 1e-4, "{r:?} ({i}, {j}): {p:?}");
            }
        }
        assert!((img.pixel(atlas::AMBIENT.x, atlas::AMBIENT.y)[1] - 0.25).abs() < 1e-6);
        assert_eq!(img.pixel(200, 400), &[0.0, 0.0, 0.0]);
        assert!(has_playcanvas_roughness(&chain));
        let wrong = MipChain { levels: chain.levels.clone(), roughness: vec![0.0; 7] };
        assert!(!has_playcanvas_roughness(&wrong));
        let short = MipChain { levels: chain.levels[..6].to_vec(), roughness: vec![0.0; 6] };
        assert!(env_atlas(&short, &cube(0.25, 8)).unwrap_err().contains("takes 7"));
    }

    /// Each rough rect and the ambient rect hold their cube read at the direction PlayCanvas
    /// stores at each texel (`playcanvas_atlas::direction`, seams included): with radiance linear
    /// in the direction, each texel equals that function at its direction to the bilinear
    /// lookup's error on a 64 cube (under 2e-3 here); a rect read mirrored, turned or transposed
    /// would be off by up to the function's range (1.5).
    #[test]
    fn each_rough_and_ambient_texel_holds_its_cube_at_its_direction() {
        let f = |d: DVec3| [1.0 + 0.5 * d.x, 1.0 + 0.5 * d.y, 1.0 + 0.5 * d.z].map(|v| v as f32);
        let cube = |s: usize| Cubemap::from_fn(s, |face, x, y| f(cube::texel_direction(face, x, y, s)));
        let chain = MipChain { levels: (0..7).map(|_| cube(64)).collect(), roughness: atlas::chain_roughness() };
        let img = env_atlas(&chain, &cube(64)).unwrap();
        let mut worst = 0.0f32;
        for r in atlas::rough_rects().into_iter().chain([atlas::AMBIENT]) {
            for j in 0..r.h {
                for i in 0..r.w {
                    let want = f(atlas::direction(r, i, j));
                    let got = img.pixel(r.x + i, r.y + j);
                    worst = (0..3).map(|k| (got[k] - want[k]).abs()).fold(worst, f32::max);
                }
            }
        }
        assert!(worst < 2e-3, "worst texel {worst}");
    }
}
