//! What `hdrflow bake MAP --for ENGINE` runs: the preset's shipped pipeline (`graphs/bake/ENGINE.ron`)
//! with its `{name}` replaced by MAP's file stem and the options turned into `--set` overrides,
//! applied before the user's own (which win): `env.path` (MAP), the sizes, sample counts and
//! levels of the quality (levels follow the chain's size, also one given with `--set
//! spec.size=...`), `turned.yaw` (the yaw), `clean.replace` (sanitize), and for `Sun::Keep` every
//! input wired to `sun.residual` rewired to the map the sun was taken from, with the sun's file left
//! out. A map whose header says it is not 2:1 and a chain size the engine refuses are refused
//! before anything runs. The command line (`cli::bake`) only parses its arguments into
//! [`BakeOptions`], runs the [`Bake`] and writes the bake's notes (`super::notes`).

use std::path::{Path, PathBuf};

use super::{Preset, SpecSize};
use crate::engine::graph::{Override, Pipeline};
use crate::engine::params::ParamValue;
use crate::engine::registry::Registry;

/// `--quality`: the row of the preset's table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QualityLevel {
    Draft,
    Default,
    High,
}

/// `--sun`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sun {
    /// take the sun out with SunExtract and write it as the engine's directional light
    Extract,
    /// leave the sun in the map
    Keep,
}

/// The options of one bake.
#[derive(Clone, Debug)]
pub struct BakeOptions {
    /// the map: a path, or `builtin:NAME`
    pub map: String,
    pub quality: QualityLevel,
    /// degrees about +Y (`Rotate`'s convention)
    pub yaw: f64,
    pub sun: Sun,
    /// replace NaN and infinite texels instead of failing on them
    pub sanitize: bool,
    /// the user's `--set`, applied last
    pub user: Vec<Override>,
}

/// A validated bake: the pipeline to run and what it was made from.
pub struct Bake {
    pub preset: &'static Preset,
    /// the pipeline's text, `{name}` filled in
    pub text: String,
    /// where the text comes from (`graphs/bake/ENGINE.ron`), for messages
    pub source: String,
    /// every override applied, in order: MAP, the options', the user's
    pub overrides: Vec<Override>,
    /// the pipeline with them
    pub pipeline: Pipeline,
    /// the nodes to run: every file the engine loads (without the sun's for `Sun::Keep`) and,
    /// for `Sun::Extract`, the light itself (`sun.sun`), whose value the notes are written from
    pub targets: Vec<String>,
}

impl Preset {
    /// The folder a bake writes into when none is given: `out/bake/ENGINE`, one per engine, so
    /// that two engines' files and notes never mix.
    pub fn default_out(&self) -> PathBuf {
        Path::new("out").join("bake").join(self.name)
    }

    /// The bake of `options.map` for this engine, validated, or every reason it is refused (the
    /// message without `error: `).
    pub fn bake(&'static self, registry: &Registry, options: &BakeOptions) -> Result<Bake, String> {
        let map = &options.map;
        let text = self.pipeline.replace("{name}", &map_name(map));
        let source = format!("graphs/bake/{}.ron", self.name);
        let env = vec![set("env", "path", format!("{map:?}"))];
        let first = parse(registry, &text, &source, &[env.clone(), options.user.clone()].concat())?;
        let derived = derived_overrides(self, &first, options)?;
        let overrides = [env, derived, options.user.clone()].concat();
        let pipeline = parse(registry, &text, &source, &overrides)?;
        let targets = targets(&pipeline, options.sun);
        Ok(Bake { preset: self, text, source, overrides, pipeline, targets })
    }
}

impl Bake {
    /// A warning for a map too small for the chain the quality chose: a cube face of N texels
    /// spans 90 degrees, which a W x H lat-long map covers with H / 2 texels, so level 0 is the
    /// map upsampled N / (H / 2) times. Up to 2x (N <= H) is silent (the default sizes on a 512 x
    /// 256 map); more is said, with the size that fits, unless the user set the chain's size with
    /// `--set` (they asked for it). It is a warning, not a refusal: the bake is still right (a
    /// constant map is exact at any size), only larger than the detail it holds. A map whose
    /// size is unknown before running is not checked.
    pub fn resolution_warning(&self, options: &BakeOptions) -> Option<String> {
        let p = &self.pipeline;
        let (_, h) = p.index_of("env").and_then(|i| p.nodes[i].size)?;
        let h = h as usize;
        for (i, n) in p.nodes.iter().enumerate().filter(|(_, n)| n.spec.name == "PrefilterSpecular") {
            let Some(size) = int_param(p, i, "size") else { continue };
            if size <= h || user_sets(&options.user, &n.name, "size") {
                continue;
            }
            let fits = (h / 2).max(1);
            let fits = if self.preset.size_rule.is_some() { 1 << fits.ilog2() } else { fits };
            return Some(format!(
                "{} is {}x{h}: small for --for {} at --quality {}, whose cube faces are {size} texels across; \
                 a face spans 90 degrees, which this map covers with {} texels, so the chain's first level is \
                 the map upsampled {:.0}x, blurrier than its size says. Bake a larger map, a lower --quality, or \
                 the size the map holds: --set {}.size={fits}",
                options.map,
                2 * h,
                self.preset.name,
                format!("{:?}", options.quality).to_lowercase(),
                h / 2,
                size as f64 / (h as f64 / 2.0),
                n.name,
            ));
        }
        None
    }
}

/// The map's name in file names: its file stem, or NAME of `builtin:NAME`.
pub fn map_name(map: &str) -> String {
    if let Some(name) = map.strip_prefix("builtin:") {
        return name.to_string();
    }
    Path::new(map).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "map".into())
}

fn set(node: &str, field: &str, value: impl Into<String>) -> Override {
    Override { node: node.into(), field: field.into(), value: value.into() }
}

/// Validates the bake pipeline text with `overrides`, every error as the lines to print.
fn parse(registry: &Registry, text: &str, source: &str, overrides: &[Override]) -> Result<Pipeline, String> {
    Pipeline::parse(text, source, Path::new(""), registry, overrides).map_err(|errors| {
        let mut m = String::new();
        for (i, e) in errors.0.iter().enumerate() {
            m.push_str(&if i == 0 { e.to_string() } else { format!("\nerror: {e}") });
        }
        format!("{m}\n{} error(s) in {source}; nothing was run", errors.0.len())
    })
}

/// Whether the user's `--set` gives `node.field`.
fn user_sets(user: &[Override], node: &str, field: &str) -> bool {
    user.iter().any(|o| o.node == node && o.field == field)
}

/// An integer parameter of a validated node.
pub(super) fn int_param(p: &Pipeline, node: usize, field: &str) -> Option<usize> {
    match p.nodes[node].params.values.get(field) {
        Some(ParamValue::Int(v)) => usize::try_from(*v).ok(),
        _ => None,
    }
}

/// The overrides the quality, yaw, sanitize and sun options mean for this pipeline (`p`:
/// validated with MAP and the user's overrides), after the checks that need the map's size.
fn derived_overrides(preset: &Preset, p: &Pipeline, options: &BakeOptions) -> Result<Vec<Override>, String> {
    let (map, user) = (&options.map, &options.user);
    let env = p.index_of("env").ok_or_else(|| "the bake pipeline has no node \"env\"".to_string())?;
    let size = p.nodes[env].size;
    if let Some((w, h)) = size.filter(|(w, h)| *w != 2 * *h) {
        return Err(format!(
            "{map} is {w}x{h}, not a 2:1 lat-long (equirectangular) map, which is what hdrflow bake reads: \
             convert it first with hdrflow run (an angular probe with AngularToLatLong, a mirror ball with \
             MirrorBallToLatLong, a sky angular map with SkyAngularToLatLong, a cube cross with LayoutToCubemap \
             then CubemapToLatLong)"
        ));
    }
    let mut out = Vec::new();
    if options.sanitize {
        out.push(set("clean", "replace", "true"));
    }
    if options.yaw != 0.0 {
        out.push(set("turned", "yaw", format!("{:?}", options.yaw)));
    }
    if options.sun == Sun::Keep {
        if let Some(sun) = p.index_of("sun") {
            let residual = p.nodes[sun].ports.iter().position(|q| q.name == "residual");
            let from = p.nodes[sun].sources().next().map(|s| p.nodes[s.node].name.clone());
            for n in &p.nodes {
                for w in &n.inputs {
                    let fed = w.sources.iter().any(|s| s.node == sun && Some(s.port) == residual);
                    if let (true, Some(from)) = (fed, &from) {
                        out.push(set(&n.name, w.field, format!("{from:?}")));
                    }
                }
            }
        }
    }
    // A Resize in a bake pipeline is a cap, the largest map an engine should load as a texture:
    // a smaller map keeps its own size (and passes through unchanged). A size the user sets, on
    // either side, leaves both as given. (Every map `LoadHdr` reads has its size before running.)
    if let Some((w, h)) = size {
        let caps = p.nodes.iter().enumerate().filter(|(_, n)| n.spec.name == "Resize");
        for (i, n) in caps.filter(|(_, n)| !user_sets(user, &n.name, "width") && !user_sets(user, &n.name, "height")) {
            for (field, side) in [("width", w as usize), ("height", h as usize)] {
                if int_param(p, i, field).is_some_and(|cap| side < cap) {
                    out.push(set(&n.name, field, side.to_string()));
                }
            }
        }
    }
    let Some(rows) = preset.quality else { return Ok(out) };
    let row = rows[options.quality as usize];
    let quality_size = match row.spec_size {
        SpecSize::Fixed(s) => s,
        SpecSize::MapHeightOver(k) => {
            let (_, h) = size.ok_or_else(|| {
                format!("the size of {map} is not known before running: --for {} sizes its cube from it", preset.name)
            })?;
            (h as usize / k.max(1)).max(1)
        }
    };
    let chains: Vec<usize> = (0..p.nodes.len()).filter(|&i| p.nodes[i].spec.name == "PrefilterSpecular").collect();
    // The chain's size: the user's, if they set a chain's size, else the quality's.
    let chain_size = chains
        .iter()
        .find(|&&i| user_sets(user, &p.nodes[i].name, "size"))
        .and_then(|&i| int_param(p, i, "size"))
        .unwrap_or(quality_size);
    if let Some(rule) = preset.size_rule.filter(|_| !chain_size.is_power_of_two()) {
        let (lo, hi) = (chain_size.next_power_of_two() / 2, chain_size.next_power_of_two());
        return Err(format!(
            "--for {}: a cube size of {chain_size} is refused: {rule}; use {} or {hi}",
            preset.name,
            lo.max(1)
        ));
    }
    for (i, n) in p.nodes.iter().enumerate() {
        let mine = |field: &str| !user_sets(user, &n.name, field);
        match n.spec.name {
            "PrefilterSpecular" => {
                let size = if mine("size") { chain_size } else { int_param(p, i, "size").unwrap_or(chain_size) };
                if mine("size") {
                    out.push(set(&n.name, "size", size.to_string()));
                }
                if mine("levels") {
                    out.push(set(&n.name, "levels", preset.chain.levels(size).to_string()));
                }
                if let (Some(list), true) = (preset.level_roughness, mine("roughness_list")) {
                    let r: Vec<String> =
                        list(size, preset.chain.levels(size)).iter().map(|r| format!("{r:?}")).collect();
                    out.push(set(&n.name, "roughness_list", format!("[{}]", r.join(", "))));
                }
                if mine("samples") {
                    out.push(set(&n.name, "samples", row.samples.to_string()));
                }
            }
            "IrradianceCubemap" => {
                if let (Some(s), true) = (row.irradiance_size, mine("size")) {
                    out.push(set(&n.name, "size", s.to_string()));
                }
            }
            // The chain's source cube and the skybox, not the irradiance's small source.
            "LatLongToCubemap" | "BrdfLut" => {
                let only_irradiance = !p.consumers(i).is_empty()
                    && p.consumers(i).iter().all(|&c| p.nodes[c].spec.name == "IrradianceCubemap");
                if !only_irradiance && mine("size") {
                    out.push(set(&n.name, "size", chain_size.to_string()));
                }
            }
            _ => {}
        }
    }
    Ok(out)
}

/// The nodes to run (see [`Bake::targets`]).
fn targets(p: &Pipeline, sun: Sun) -> Vec<String> {
    let sun_node = p.index_of("sun");
    let from_sun = |i: usize| p.nodes[i].sources().any(|s| Some(s.node) == sun_node);
    let mut out: Vec<String> = (0..p.nodes.len())
        .filter(|&i| p.nodes[i].writes_file() && !(sun == Sun::Keep && from_sun(i)))
        .map(|i| p.nodes[i].name.clone())
        .collect();
    // The light and the numbers only (`sun.sun`, `sun.metrics`): naming the node would keep its
    // residual map to the end.
    if let (Sun::Extract, Some(i)) = (sun, sun_node) {
        out.push(format!("{}.sun", p.nodes[i].name));
        out.push(format!("{}.metrics", p.nodes[i].name));
    }
    out
}

/// The path the Save node `node` writes, if the pipeline has it.
pub(super) fn save_path(p: &Pipeline, node: &str) -> Option<String> {
    match p.nodes[p.index_of(node)?].params.values.get("path") {
        Some(ParamValue::Text(s)) => Some(s.clone()),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ibl_presets::PRESETS;

    /// A map whose faces would be upsampled more than 2x gets a warning with the size it holds;
    /// the same size set by the user is silent.
    #[test]
    fn a_map_too_small_for_the_chain_is_said() {
        let registry = crate::ops::builtin_registry();
        let bevy = crate::ibl_presets::preset("bevy").unwrap();
        // builtin:sky is 512 x 256: default (256) passes, high (512) is 4x.
        let mut options = BakeOptions {
            map: "builtin:sky".into(),
            quality: QualityLevel::Default,
            yaw: 0.0,
            sun: Sun::Keep,
            sanitize: false,
            user: vec![],
        };
        assert_eq!(bevy.bake(&registry, &options).unwrap().resolution_warning(&options), None, "2x is silent");
        options.quality = QualityLevel::High;
        let e = bevy.bake(&registry, &options).unwrap().resolution_warning(&options).expect("4x is said");
        assert!(e.contains("512x256") && e.contains("upsampled 4x") && e.contains("--set spec.size=128"), "{e}");
        options.user = vec![set("spec", "size", "512")];
        assert_eq!(bevy.bake(&registry, &options).unwrap().resolution_warning(&options), None, "the user's size");
    }

    /// The texture caps (a Resize in the pipeline): a smaller map keeps its size, a larger one is
    /// shrunk to the cap, and the user's size wins.
    #[test]
    fn the_texture_caps_never_enlarge_a_map() {
        let registry = crate::ops::builtin_registry();
        let dir = std::env::temp_dir().join(format!("hdrflow-bake-cap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Only the header is read before running: a 16384 x 8192 map's header and no pixels.
        let big = dir.join("big.hdr");
        std::fs::write(&big, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 16384\n").unwrap();
        let size_of = |preset: &str, map: &str, node: &str, user: Vec<Override>| {
            let options = BakeOptions {
                map: map.into(),
                quality: QualityLevel::Default,
                yaw: 0.0,
                sun: Sun::Extract,
                sanitize: false,
                user,
            };
            let bake = crate::ibl_presets::preset(preset).unwrap().bake(&registry, &options).unwrap();
            let i = bake.pipeline.index_of(node).unwrap();
            (int_param(&bake.pipeline, i, "width").unwrap(), int_param(&bake.pipeline, i, "height").unwrap())
        };
        let big = big.display().to_string();
        assert_eq!(size_of("playcanvas", "builtin:sky", "sky_fit", vec![]), (512, 256));
        assert_eq!(size_of("playcanvas", &big, "sky_fit", vec![]), (4096, 2048));
        assert_eq!(size_of("three", "builtin:sky", "map_fit", vec![]), (512, 256));
        assert_eq!(size_of("three", &big, "map_fit", vec![]), (4096, 2048));
        let mine = vec![set("map_fit", "width", "8192"), set("map_fit", "height", "4096")];
        assert_eq!(size_of("three", &big, "map_fit", mine), (8192, 4096));
        // One side set by the user leaves the other as the pipeline gives it.
        assert_eq!(size_of("three", "builtin:sky", "map_fit", vec![set("map_fit", "width", "256")]), (256, 2048));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn map_names_are_file_stems() {
        assert_eq!(map_name("builtin:sky"), "sky");
        assert_eq!(map_name("assets/maps/rooitou_park_1k.hdr"), "rooitou_park_1k");
        assert_eq!(map_name("x.y.exr"), "x.y");
    }

    #[test]
    fn each_engine_bakes_into_its_own_folder() {
        let outs: Vec<PathBuf> = PRESETS.iter().map(|p| p.default_out()).collect();
        assert_eq!(outs[1], Path::new("out/bake/bevy"));
        for (i, a) in outs.iter().enumerate() {
            assert!(outs[i + 1..].iter().all(|b| b != a), "{}", a.display());
        }
    }

    /// Every shipped pipeline validates, and agrees with its preset: the cube frame of its
    /// cube maps, the roughness map of its chains, the default quality's sizes and samples, and
    /// levels that follow the chain rule; its Save nodes write exactly the preset's `files`, in
    /// order; every `{file:NODE}` of its code names a Save node.
    #[test]
    fn each_pipeline_agrees_with_its_preset() {
        let registry = crate::ops::builtin_registry();
        for preset in PRESETS {
            let text = preset.pipeline.replace("{name}", "sky");
            let p = Pipeline::parse(&text, preset.name, Path::new(""), &registry, &[]).expect("validates");
            let choice = |i: usize, f: &str| match p.nodes[i].params.values.get(f) {
                Some(ParamValue::Choice(c)) => c.clone(),
                other => panic!("{}: {f} = {other:?}", p.nodes[i].name),
            };
            for (i, n) in p.nodes.iter().enumerate() {
                match n.spec.name {
                    "LatLongToCubemap" => {
                        assert_eq!(Some(choice(i, "frame").as_str()), preset.cube_frame.map(|f| f.name()), "{}", n.name)
                    }
                    "PrefilterSpecular" => {
                        assert_eq!(Some(choice(i, "roughness_map").as_str()), preset.roughness_map.map(|m| m.name()));
                        let row = preset.quality.expect("a chain has quality rows")[1];
                        let size = int_param(&p, i, "size").unwrap();
                        if let SpecSize::Fixed(s) = row.spec_size {
                            assert_eq!(size, s, "{}: {}", preset.name, n.name);
                        } else {
                            assert_eq!(size, 128, "builtin:sky is 512x256: H/2");
                        }
                        assert_eq!(int_param(&p, i, "levels"), Some(preset.chain.levels(size)), "{}", preset.name);
                        assert_eq!(int_param(&p, i, "samples"), Some(row.samples));
                        if let Some(list) = preset.level_roughness {
                            let levels = preset.chain.levels(size);
                            let want = ParamValue::Tuple(list(size, levels));
                            assert_eq!(p.nodes[i].params.values.get("roughness_list"), Some(&want), "{}", preset.name);
                        }
                    }
                    "IrradianceCubemap" => {
                        let row = preset.quality.expect("quality rows")[1];
                        assert_eq!(int_param(&p, i, "size"), row.irradiance_size, "{}", preset.name);
                    }
                    _ => {}
                }
            }
            let saved: Vec<String> = (0..p.nodes.len())
                .filter(|&i| p.nodes[i].spec.name == "Save")
                .filter_map(|i| save_path(&p, &p.nodes[i].name))
                .collect();
            assert_eq!(
                saved.join(", "),
                preset.files.replace("{name}", "sky"),
                "{}: Save paths and files",
                preset.name
            );
            for code in [preset.loading_code, preset.sun_code] {
                let filled = crate::ibl_presets::notes::fill_files(code, &p);
                assert!(!filled.contains("{file:"), "{}: {filled}", preset.name);
                for part in code.split("{file:").skip(1) {
                    let node = &part[..part.find('}').unwrap()];
                    assert!(save_path(&p, node).is_some(), "{}: {{file:{node}}} is no Save node", preset.name);
                }
            }
        }
    }
}
