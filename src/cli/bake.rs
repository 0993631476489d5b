//! `hdrflow bake MAP --for ENGINE`: a front for `run` over the engine's shipped pipeline
//! (`ibl_presets`, `graphs/bake/ENGINE.ron`). The pipeline's `{name}` becomes MAP's file stem;
//! the options become `--set` overrides applied before the user's own (which win): `env.path`
//! (MAP), the sizes, sample counts and levels of `--quality` (levels follow the chain's size,
//! also one given with `--set spec.size=...`), `turned.yaw` (`--yaw`), `clean.replace`
//! (`--sanitize`), and for `--sun keep` every input wired to `sun.residual` rewired to the map
//! the sun was taken from, with the sun's file left out. Before anything runs, a map whose
//! header says it is not 2:1 and a chain size the engine refuses are usage errors (exit 2).
//! After the run, `README.txt` in the output folder lists the files and the engine code that
//! loads them (with the extracted sun's numbers in the engine's units).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use super::progress;
use crate::engine::cache::store::DEFAULT_LIMIT_BYTES;
use crate::engine::cache::CacheStore;
use crate::engine::graph::{Override, Pipeline};
use crate::engine::params::ParamValue;
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions};
use crate::ibl_presets::{self, Preset, SpecSize};
use crate::values::Light;

/// `--quality`: the row of the preset's table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(super) enum QualityArg {
    Draft,
    Default,
    High,
}

/// `--sun`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(super) enum SunArg {
    /// take the sun out with SunExtract and write it as the engine's directional light
    Extract,
    /// leave the sun in the map
    Keep,
}

#[derive(Args)]
pub(super) struct BakeArgs {
    /// The environment map: a 2:1 lat-long .hdr, .exr or .pfm, or builtin:NAME (builtin:sky).
    #[arg(required_unless_present = "print_pipeline")]
    pub(super) map: Option<String>,
    /// The engine: bevy, filament, khronos or three.
    #[arg(long = "for", value_name = "ENGINE")]
    pub(super) engine: String,
    /// Output folder.
    #[arg(long, default_value = "out")]
    pub(super) out: PathBuf,
    /// Sizes and sample counts: draft, default (what the engine's own tool uses), high.
    #[arg(long, value_enum, default_value_t = QualityArg::Default)]
    pub(super) quality: QualityArg,
    /// Turn the map about +Y by this many degrees first (a positive yaw turns forward, -Z,
    /// towards -X); the book (docs/src/guides/baking/index.md) says which yaw reproduces each engine's own tool.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "DEGREES")]
    pub(super) yaw: f64,
    /// extract (default: measured more accurate, docs/src/benchmarks/ibl.md): the sun becomes the engine's
    /// directional light; keep: it stays in the map.
    #[arg(long, value_enum, default_value_t = SunArg::Extract)]
    pub(super) sun: SunArg,
    /// Replace NaN and infinite texels (NaN, -Inf -> 0; +Inf -> the largest finite value)
    /// instead of failing on them.
    #[arg(long)]
    pub(super) sanitize: bool,
    /// Override one field of the pipeline: NODE.FIELD=RON_VALUE (repeatable), as in `run`.
    #[arg(long = "set", value_name = "NODE.FIELD=VALUE")]
    pub(super) set: Vec<String>,
    /// Print the pipeline the bake runs (with the overrides it applies) and exit.
    #[arg(long)]
    pub(super) print_pipeline: bool,
    /// Cache folder (default: $HDRFLOW_CACHE_DIR, $XDG_CACHE_HOME/hdrflow or ~/.cache/hdrflow).
    #[arg(long)]
    pub(super) cache_dir: Option<PathBuf>,
    /// Compute everything; neither read nor write the cache.
    #[arg(long)]
    pub(super) no_cache: bool,
    /// Worker threads; 0 or absent: one per core.
    #[arg(long)]
    pub(super) jobs: Option<usize>,
    /// Print only errors and warnings.
    #[arg(long, short, conflicts_with = "verbose")]
    pub(super) quiet: bool,
    /// Also print one line per node as it finishes, and the per-node table at the end.
    #[arg(long, short)]
    pub(super) verbose: bool,
}

/// A usage or pipeline error: the message (without `error: `) and exit code 2.
struct Refused(String);

/// The map's name in file names: its file stem, or NAME of `builtin:NAME`.
fn map_name(map: &str) -> String {
    if let Some(name) = map.strip_prefix("builtin:") {
        return name.to_string();
    }
    Path::new(map).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "map".into())
}

fn set(node: &str, field: &str, value: impl Into<String>) -> Override {
    Override { node: node.into(), field: field.into(), value: value.into() }
}

/// Validates the bake pipeline text with `overrides`, every error as the lines to print.
fn parse(registry: &Registry, text: &str, source: &str, overrides: &[Override]) -> Result<Pipeline, Refused> {
    Pipeline::parse(text, source, Path::new(""), registry, overrides).map_err(|errors| {
        let mut m = String::new();
        for (i, e) in errors.0.iter().enumerate() {
            m.push_str(&if i == 0 { e.to_string() } else { format!("\nerror: {e}") });
        }
        Refused(format!("{m}\n{} error(s) in {source}; nothing was run", errors.0.len()))
    })
}

/// Whether the user's `--set` gives `node.field`.
fn user_sets(user: &[Override], node: &str, field: &str) -> bool {
    user.iter().any(|o| o.node == node && o.field == field)
}

/// An integer parameter of a validated node.
fn int_param(p: &Pipeline, node: usize, field: &str) -> Option<usize> {
    match p.nodes[node].params.values.get(field) {
        Some(ParamValue::Int(v)) => usize::try_from(*v).ok(),
        _ => None,
    }
}

/// The overrides `--quality`, `--yaw`, `--sanitize` and `--sun` mean for this pipeline (`p`:
/// validated with MAP and the user's overrides), after the checks that need the map's size.
fn derived_overrides(
    preset: &Preset,
    p: &Pipeline,
    args: &BakeArgs,
    user: &[Override],
    map: &str,
) -> Result<Vec<Override>, Refused> {
    let env = p.index_of("env").ok_or_else(|| Refused("the bake pipeline has no node \"env\"".into()))?;
    let size = p.nodes[env].size;
    if let Some((w, h)) = size.filter(|(w, h)| *w != 2 * *h) {
        return Err(Refused(format!(
            "{map} is {w}x{h}, not a 2:1 lat-long (equirectangular) map, which is what hdrflow bake reads: \
             convert it first with hdrflow run (an angular probe with AngularToLatLong, a mirror ball with \
             MirrorBallToLatLong, a sky angular map with SkyAngularToLatLong, a cube cross with LayoutToCubemap \
             then CubemapToLatLong)"
        )));
    }
    let mut out = Vec::new();
    if args.sanitize {
        out.push(set("clean", "replace", "true"));
    }
    if args.yaw != 0.0 {
        out.push(set("turned", "yaw", format!("{:?}", args.yaw)));
    }
    if args.sun == SunArg::Keep {
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
    let Some(rows) = preset.quality else { return Ok(out) };
    let row = rows[args.quality as usize];
    let quality_size = match row.spec_size {
        SpecSize::Fixed(s) => s,
        SpecSize::MapHeightOver(k) => {
            let (_, h) = size.ok_or_else(|| {
                Refused(format!(
                    "the size of {map} is not known before running: --for {} sizes its cube from it",
                    preset.name
                ))
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
        return Err(Refused(format!(
            "--for {}: a cube size of {chain_size} is refused: {rule}; use {} or {hi}",
            preset.name,
            lo.max(1)
        )));
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

/// The nodes to run: every file the engine loads (without the sun's for `--sun keep`) and,
/// for `--sun extract`, the sun itself, whose value the README's light is written from.
fn targets(p: &Pipeline, sun: SunArg) -> Vec<String> {
    let sun_node = p.index_of("sun");
    let from_sun = |i: usize| p.nodes[i].sources().any(|s| Some(s.node) == sun_node);
    let mut out: Vec<String> = (0..p.nodes.len())
        .filter(|&i| p.nodes[i].writes_file() && !(sun == SunArg::Keep && from_sun(i)))
        .map(|i| p.nodes[i].name.clone())
        .collect();
    // The light only (`sun.sun`): naming the node would keep its residual map to the end.
    if let (SunArg::Extract, Some(i)) = (sun, sun_node) {
        out.push(format!("{}.sun", p.nodes[i].name));
    }
    out
}

/// The path the Save node `node` writes, if the pipeline has it.
fn save_path(p: &Pipeline, node: &str) -> Option<String> {
    match p.nodes[p.index_of(node)?].params.values.get("path") {
        Some(ParamValue::Text(s)) => Some(s.clone()),
        _ => None,
    }
}

/// `text` with every `{file:NODE}` replaced by the path NODE writes.
fn fill_files(text: &str, p: &Pipeline) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(start) = rest.find("{file:") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 6..];
        let end = after.find('}').unwrap_or(after.len());
        out.push_str(&save_path(p, &after[..end]).unwrap_or_else(|| after[..end].to_string()));
        rest = after.get(end + 1..).unwrap_or("");
    }
    out.push_str(rest);
    out
}

fn triple(v: [f64; 3]) -> String {
    format!("{:.6}, {:.6}, {:.6}", v[0], v[1], v[2])
}

/// The sun's numbers in `sun_code`: `{sun:illuminance}` (the Rec. 709 luminance of the
/// irradiance `radiance * solid_angle` it gives a surface facing it, in the map's units),
/// `{sun:color}` (that irradiance divided by it: linear Rec. 709), `{sun:to_light}`,
/// `{sun:from_light}` and `{sun:radius_deg}` (the cone of its solid angle).
pub(super) fn fill_sun(text: &str, sun: &Light) -> String {
    let e = sun.power();
    let y: f64 = e.iter().zip(crate::colour::REC709).map(|(a, b)| a * b).sum();
    let colour = if y > 0.0 { e.map(|v| v / y) } else { [1.0; 3] };
    let d = sun.direction;
    let radius = (1.0 - sun.solid_angle / (2.0 * std::f64::consts::PI)).clamp(-1.0, 1.0).acos().to_degrees();
    text.replace("{sun:illuminance}", &format!("{y:.6}"))
        .replace("{sun:color}", &triple(colour))
        .replace("{sun:to_light}", &triple(d))
        .replace("{sun:from_light}", &triple(d.map(|v| -v)))
        .replace("{sun:radius_deg}", &format!("{radius:.4}"))
}

/// README.txt: what was baked, the files, and the engine code that loads them.
fn readme(
    preset: &Preset,
    p: &Pipeline,
    args: &BakeArgs,
    map: &str,
    written: &[String],
    sun: Option<&Light>,
) -> String {
    let mut out = format!(
        "hdrflow bake {map} --for {} (quality {:?}, yaw {}, sun {:?}{})\n\n{}\n\nConventions: {}; {}; irradiance: {}.\n\nFiles:\n",
        preset.name,
        args.quality,
        args.yaw,
        args.sun,
        if args.sanitize { ", sanitized" } else { "" },
        preset.loads,
        preset.world,
        preset.lod,
        preset.irradiance
    );
    for f in written {
        out.push_str(&format!("  {f}\n"));
    }
    out.push('\n');
    out.push_str(&fill_files(preset.loading_code, p));
    match sun {
        Some(s) if s.solid_angle > 0.0 => {
            out.push('\n');
            out.push_str(&fill_sun(&fill_files(preset.sun_code, p), s));
        }
        Some(_) => {
            out.push_str("\n// No sun was found above the threshold (SunExtract): no directional light to add.\n")
        }
        None => {}
    }
    out
}

pub(super) fn bake(registry: &Registry, args: &BakeArgs) -> ExitCode {
    match bake_inner(registry, args) {
        Ok(code) => code,
        Err(Refused(m)) => {
            eprintln!("error: {m}");
            ExitCode::from(2)
        }
    }
}

fn bake_inner(registry: &Registry, args: &BakeArgs) -> Result<ExitCode, Refused> {
    let preset = ibl_presets::preset(&args.engine).ok_or_else(|| {
        Refused(format!(
            "--for {:?}: no such engine; hdrflow bake writes for {}",
            args.engine,
            ibl_presets::names().join(", ")
        ))
    })?;
    if args.out.exists() && !args.out.is_dir() {
        return Err(Refused(format!(
            "--out {}: is a file; --out names the folder the bake writes into",
            args.out.display()
        )));
    }
    let map = args.map.clone().unwrap_or_else(|| "builtin:sky".into());
    let text = preset.pipeline.replace("{name}", &map_name(&map));
    let source = format!("graphs/bake/{}.ron", preset.name);
    let mut user = Vec::new();
    for s in &args.set {
        user.push(Override::parse(s).map_err(Refused)?);
    }
    let env = vec![set("env", "path", format!("{map:?}"))];
    let first = parse(registry, &text, &source, &[env.clone(), user.clone()].concat())?;
    let derived = derived_overrides(preset, &first, args, &user, &map)?;
    let overrides = [env, derived, user].concat();
    let p = parse(registry, &text, &source, &overrides)?;
    if args.print_pipeline {
        out!("// hdrflow bake {map} --for {}: this pipeline, run with\n", preset.name);
        for o in &overrides {
            out!("//   --set {}.{}={}\n", o.node, o.field, o.value);
        }
        out!("{text}");
        return Ok(ExitCode::SUCCESS);
    }
    let verbosity = if args.quiet {
        progress::Verbosity::Quiet
    } else if args.verbose {
        progress::Verbosity::Verbose
    } else {
        progress::Verbosity::Normal
    };
    let observer = progress::Progress::new(verbosity);
    let cache = (!args.no_cache)
        .then(|| CacheStore::new(args.cache_dir.clone().unwrap_or_else(CacheStore::default_dir), DEFAULT_LIMIT_BYTES));
    let options = RunOptions {
        targets: targets(&p, args.sun),
        out_dir: args.out.clone(),
        cache,
        jobs: args.jobs.filter(|&j| j > 0),
        observer: &observer,
    };
    let outcome = scheduler::run(&p, &options);
    observer.finish();
    let outcome = match outcome {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(ExitCode::from(super::run::run_error_code(&e)));
        }
    };
    let report = &outcome.report;
    let written: Vec<String> =
        report.written.iter().map(|f| f.strip_prefix(&args.out).unwrap_or(f).display().to_string()).collect();
    let sun = outcome.values.get("sun").and_then(|v| v.get::<Light>());
    let text = readme(preset, &p, args, &map, &written, sun);
    let readme_path = args.out.join("README.txt");
    if let Err(e) = crate::engine::cache::store::write_atomic(&readme_path, text.as_bytes()) {
        eprintln!("error: writing {}: {e}", readme_path.display());
        return Ok(ExitCode::from(1));
    }
    if let Some(c) = options.cache.as_ref().filter(|c| c.root().is_dir()) {
        if let Err(e) = c.evict() {
            eprintln!("warning: cache pruning: {e}");
        }
    }
    if !args.quiet {
        if args.verbose {
            progress::print_table(report);
        }
        outln!(
            "{}: {} nodes: {} computed, {} cached; {:.1} ms; {} files and README.txt written to {}",
            preset.name,
            report.nodes.len(),
            report.count(NodeStatus::Computed),
            report.count(NodeStatus::Cached),
            report.total_ms,
            written.len(),
            args.out.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ibl_presets::PRESETS;

    #[test]
    fn map_names_are_file_stems() {
        assert_eq!(map_name("builtin:sky"), "sky");
        assert_eq!(map_name("assets/maps/rooitou_park_1k.hdr"), "rooitou_park_1k");
        assert_eq!(map_name("x.y.exr"), "x.y");
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
                let filled = fill_files(code, &p);
                assert!(!filled.contains("{file:"), "{}: {filled}", preset.name);
                for part in code.split("{file:").skip(1) {
                    let node = &part[..part.find('}').unwrap()];
                    assert!(save_path(&p, node).is_some(), "{}: {{file:{node}}} is no Save node", preset.name);
                }
            }
        }
    }

    #[test]
    fn sun_numbers_are_the_irradiance_it_gives() {
        let sun = Light { direction: [0.0, 0.6, -0.8], solid_angle: 6e-5, radiance: [5e4, 4e4, 3e4] };
        let text = fill_sun("{sun:illuminance}|{sun:color}|{sun:from_light}|{sun:radius_deg}", &sun);
        let parts: Vec<&str> = text.split('|').collect();
        let y = 6e-5 * (0.2126 * 5e4 + 0.7152 * 4e4 + 0.0722 * 3e4);
        assert_eq!(parts[0], format!("{y:.6}"));
        assert!(parts[1].starts_with(&format!("{:.6}", 3.0 / y)), "{}", parts[1]);
        assert_eq!(parts[2], "-0.000000, -0.600000, 0.800000");
        let r: f64 = parts[3].parse().unwrap();
        assert!((r - 0.2502).abs() < 1e-3, "{r}");
    }
}
