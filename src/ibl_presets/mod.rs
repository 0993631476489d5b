//! What each engine's image-based lighting expects, declared once per engine (one file each):
//! its world and the frame its cube maps are sampled in, the roughness each level of its chain
//! stands for, how it reads irradiance, the files it loads and their names, the sizes and
//! sample counts its own baking tool uses, and the engine code of its bake's notes. `hdrflow bake
//! MAP --for ENGINE` runs the engine's shipped pipeline (`graphs/bake/ENGINE.ron`, embedded here)
//! with the overrides these declarations give (`bake`: [`Preset::bake`]), into the engine's own
//! folder (`Preset::default_out`, guarded by `Preset::check_out`), and writes its notes
//! (`notes`); a test checks that each pipeline agrees with its preset (frame, roughness map,
//! default sizes, file names).
//!
//! Every preset puts the map's centre where hdrflow's lat-long convention puts it, forward (-Z),
//! in the engine's world, never mirrored (`--yaw` turns it; the tables of docs/src/guides/baking/index.md say which
//! yaw reproduces the engine's own tool). Bevy, Filament, the Khronos viewers and three.js are
//! right-handed with +Y up, as hdrflow is, so a direction means the same in hdrflow and in the
//! engine: only the cube lookup (`geometry::cube_frame`) and, for three.js, its own lat-long
//! mapping differ. Babylon.js is left-handed by default (+Z forward): its `(x, y, z)` is hdrflow's
//! `(X, Y, -Z)`, so the map's centre faces its default camera (`babylon.rs`); so is the glTF
//! asset's light, which Babylon's glTF loader makes its environment (`gltf.rs`). PlayCanvas is
//! right-handed with +Y up too, but its equirect puts +Z at the centre: its atlas is written by
//! world direction and its skybox turned by half a turn (`playcanvas.rs`).

pub mod babylon;
pub mod bake;
pub mod bevy;
pub mod filament;
pub mod gltf;
pub mod khronos;
pub mod notes;
pub mod playcanvas;
pub mod three;

use crate::geometry::cube_frame::CubeFrame;
use crate::maths::brdf::specular_lobe::RoughnessMap;

crate::choice! {
    /// An engine `hdrflow bake` writes for.
    pub enum Engine {
        /// Babylon.js (a .env file: its prefiltered cube as RGBD PNGs and its irradiance polynomial)
        Babylon,
        /// Bevy's EnvironmentMapLight (two KTX2 cube maps)
        Bevy,
        /// Filament's IndirectLight (what cmgen writes: a reflections cube map and 9 SH)
        Filament,
        /// a glTF 2.0 asset with an EXT_lights_image_based light (Babylon.js's glTF loader)
        Gltf,
        /// the Khronos glTF Sample Viewer and Vulkan samples (glTF-IBL-Sampler's files)
        Khronos,
        /// PlayCanvas (app.scene.envAtlas: its RGBP atlas of reflection levels and ambient, and a skybox)
        Playcanvas,
        /// three.js (an equirectangular map it prefilters itself, and SH for a LightProbe)
        Three,
    }
}

/// How big the specular chain's first level is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpecSize {
    /// this many texels per face
    Fixed(usize),
    /// the map's height divided by this (glTF-IBL-Sampler: a W x H panorama gives an H/2 cube)
    MapHeightOver(usize),
}

/// The sizes and sample count of one `--quality`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    /// face size of the chain's level 0 (and of the source cube it is filtered from)
    pub spec_size: SpecSize,
    /// samples per texel of the chain
    pub samples: usize,
    /// face size of the irradiance cube map (`None`: the engine loads none)
    pub irradiance_size: Option<usize>,
}

/// Which levels the chain has.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Chain {
    /// every level down to 1 x 1: `floor(log2(size)) + 1` levels (Bevy, glTF viewers)
    ToOneTexel,
    /// down to faces of this size (cmgen: 16, so 5 levels from 256)
    ToSize(usize),
    /// no cube chain (three.js prefilters the equirectangular map itself)
    None,
    /// this many levels, whatever the size (PlayCanvas' atlas: the map and 6 rough levels)
    Levels(usize),
}

impl Chain {
    /// The number of levels of a chain whose level 0 has `size` texels per face.
    pub fn levels(self, size: usize) -> usize {
        let log2 = |s: usize| (usize::BITS - 1 - s.max(1).leading_zeros()) as usize;
        match self {
            Chain::ToOneTexel => log2(size) + 1,
            // cmgen: a minimum at or above the size means the whole chain.
            Chain::ToSize(min) if min.max(1) < size => log2(size) - log2(min.max(1)) + 1,
            Chain::ToSize(_) => log2(size) + 1,
            Chain::None => 1,
            Chain::Levels(n) => n,
        }
    }
}

/// Where one tool of the engine's ecosystem puts a lat-long map's centre, and the `--yaw` that
/// makes hdrflow's preset put it there too (a mirror cannot be reproduced: a preset is never
/// mirrored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolPlacement {
    /// the tool and how it is run
    pub tool: &'static str,
    /// the world direction the map's centre faces in the engine
    pub centre: &'static str,
    /// whether the panorama comes out mirrored (text reads right to left from inside)
    pub mirrored: bool,
    /// the yaw (degrees, hdrflow's `Rotate` convention) that moves hdrflow's centre there
    pub yaw: f64,
}

/// A preset's check of its output folder (`Preset::check_assets`): the folder, the map's name,
/// whether the folder holds this engine's notes.
pub type CheckAssets = fn(&std::path::Path, &str, bool) -> Result<(), String>;

/// One engine's conventions.
#[derive(Clone, Copy, Debug)]
pub struct Preset {
    pub engine: Engine,
    /// the name `--for` takes
    pub name: &'static str,
    /// what the engine loads, in its own words
    pub loads: &'static str,
    /// the engine's world axes
    pub world: &'static str,
    /// the lookup its cube maps are written for (`None`: no cube map is written)
    pub cube_frame: Option<CubeFrame>,
    /// the roughness each level stands for (`None`: no chain is written)
    pub roughness_map: Option<RoughnessMap>,
    /// for `RoughnessMap::List`: each level's roughness for a chain of this size and level count
    /// (the bake sets the chain's `roughness_list` with it)
    pub level_roughness: Option<fn(usize, usize) -> Vec<f64>>,
    /// how the engine's shader picks a level
    pub lod: &'static str,
    /// how it reads diffuse light, and in what units
    pub irradiance: &'static str,
    /// the files written (`{name}` is the map's file stem)
    pub files: &'static str,
    /// their texel formats
    pub texel_formats: &'static str,
    /// the yaw (degrees) the pipeline adds so that hdrflow's centre lands at -Z in the engine
    pub centre_yaw: f64,
    /// where the engine's own tools put the centre
    pub tools: &'static [ToolPlacement],
    /// `--quality draft`, `default`, `high` (`None`: nothing is filtered, the map keeps its size)
    pub quality: Option<[Quality; 3]>,
    /// the chain's levels
    pub chain: Chain,
    /// why a level-0 size is refused (`None`: any size)
    pub size_rule: Option<&'static str>,
    /// what else in the output folder the bake must not mix with (`None`: only another engine's
    /// bake, `Preset::check_out`): given the folder, the map's name and whether the folder holds
    /// this engine's notes; the message without `error: ` (glTF: another asset, `gltf.rs`)
    pub check_assets: Option<CheckAssets>,
    /// the pipeline file (`graphs/bake/<name>.ron`)
    pub pipeline: &'static str,
    /// the lines of engine code that load the files (`{file:NODE}` stands for the path the Save
    /// node NODE writes)
    pub loading_code: &'static str,
    /// the lines that add the extracted sun as the engine's light (`{sun:...}` fields: see
    /// `notes::fill_sun`)
    pub sun_code: &'static str,
}

/// Every preset, in `Engine` order.
pub const PRESETS: [&Preset; 7] = [
    &babylon::PRESET,
    &bevy::PRESET,
    &filament::PRESET,
    &gltf::PRESET,
    &khronos::PRESET,
    &playcanvas::PRESET,
    &three::PRESET,
];

/// The preset `--for NAME` names (any case), or `None`.
pub fn preset(name: &str) -> Option<&'static Preset> {
    let engine = Engine::from_name_ignore_case(name)?;
    PRESETS.iter().copied().find(|p| p.engine == engine)
}

/// The names `--for` accepts, for messages.
pub fn names() -> Vec<&'static str> {
    PRESETS.iter().map(|p| p.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_levels_follow_each_rule() {
        assert_eq!(Chain::ToOneTexel.levels(256), 9);
        assert_eq!(Chain::ToOneTexel.levels(1), 1);
        assert_eq!(Chain::ToOneTexel.levels(300), 9);
        assert_eq!(Chain::ToSize(16).levels(256), 5);
        assert_eq!(Chain::ToSize(16).levels(16), 5);
        assert_eq!(Chain::ToSize(16).levels(8), 4);
        assert_eq!(Chain::None.levels(256), 1);
    }

    #[test]
    fn every_engine_has_one_preset_named_for_it() {
        for (p, e) in PRESETS.iter().zip(Engine::ALL) {
            assert_eq!(p.engine, e);
            assert_eq!(p.name, e.name().to_lowercase());
            assert_eq!(preset(p.name).map(|q| q.engine), Some(e));
        }
        assert_eq!(preset("BEVY").map(|p| p.engine), Some(Engine::Bevy));
        assert!(preset("unity").is_none());
    }
}
