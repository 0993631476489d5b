//! `hdrflow bake MAP --for ENGINE`: its arguments, and the run of the engine's bake
//! (`ibl_presets::bake`: the shipped pipeline with the overrides the options stand for) with
//! `run`'s cache, progress and summary. The output folder is `--out`, else the engine's own
//! (`out/bake/ENGINE`), refused when it holds another engine's bake; after the run, the bake's notes
//! (`README.txt`: the files and the engine code that loads them, `ibl_presets::notes`) go beside
//! the files. A refused map, size or folder is a usage error (exit 2), before anything runs.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use super::progress;
use crate::engine::cache::store::DEFAULT_LIMIT_BYTES;
use crate::engine::cache::CacheStore;
use crate::engine::graph::Override;
use crate::engine::registry::Registry;
use crate::engine::scheduler::{self, NodeStatus, RunOptions};
use crate::ibl_presets::bake::{BakeOptions, QualityLevel, Sun};
use crate::ibl_presets::notes::{self, NOTES_FILE};
use crate::ibl_presets::{self, Preset};
use crate::values::{Light, Metrics};

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
    /// The engine: babylon (a Babylon.js .env), bevy, filament, gltf (a glTF 2.0 asset with an
    /// EXT_lights_image_based light), khronos, playcanvas (its envAtlas and skybox) or three.
    #[arg(long = "for", value_name = "ENGINE")]
    pub(super) engine: String,
    /// Output folder (default: out/bake/ENGINE); one holding another engine's bake is refused,
    /// and for gltf one holding another .gltf/.glb asset than an earlier gltf bake of this map.
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
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

impl BakeArgs {
    /// The options of the bake (the map `builtin:sky` when none is given, for `--print-pipeline`).
    fn options(&self) -> Result<BakeOptions, Refused> {
        let user = self.set.iter().map(|s| Override::parse(s)).collect::<Result<Vec<_>, _>>().map_err(Refused)?;
        Ok(BakeOptions {
            map: self.map.clone().unwrap_or_else(|| "builtin:sky".into()),
            quality: match self.quality {
                QualityArg::Draft => QualityLevel::Draft,
                QualityArg::Default => QualityLevel::Default,
                QualityArg::High => QualityLevel::High,
            },
            yaw: self.yaw,
            sun: match self.sun {
                SunArg::Extract => Sun::Extract,
                SunArg::Keep => Sun::Keep,
            },
            sanitize: self.sanitize,
            user,
        })
    }
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
    let preset: &'static Preset = ibl_presets::preset(&args.engine).ok_or_else(|| {
        let names = ibl_presets::names();
        // "; did you mean ..." for a close name only: the list follows anyway.
        let close = crate::engine::graph::suggest(&args.engine, &names, "engines");
        let close = if close.starts_with("; did you mean") { format!("{close} ") } else { "; ".into() };
        Refused(format!("--for {:?}: no such engine{close}hdrflow bake writes for {}", args.engine, names.join(", ")))
    })?;
    let out_dir = args.out.clone().unwrap_or_else(|| preset.default_out());
    if !args.print_pipeline {
        let map = ibl_presets::bake::map_name(args.map.as_deref().unwrap_or("builtin:sky"));
        preset.check_out(&out_dir, &map).map_err(Refused)?;
    }
    let options = args.options()?;
    let bake = preset.bake(registry, &options).map_err(Refused)?;
    if let Some(w) = bake.resolution_warning(&options).filter(|_| !args.print_pipeline) {
        eprintln!("warning: {w}");
    }
    if args.print_pipeline {
        out!("// hdrflow bake {} --for {}: this pipeline, run with\n", options.map, preset.name);
        for o in &bake.overrides {
            out!("//   --set {}.{}={}\n", o.node, o.field, o.value);
        }
        out!("{}", bake.text);
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
    let run_options = RunOptions {
        targets: bake.targets.clone(),
        out_dir: out_dir.clone(),
        cache,
        jobs: args.jobs.filter(|&j| j > 0),
        observer: &observer,
    };
    let outcome = scheduler::run(&bake.pipeline, &run_options);
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
        report.written.iter().map(|f| f.strip_prefix(&out_dir).unwrap_or(f).display().to_string()).collect();
    let sun = outcome.values.get("sun").and_then(|v| v.get::<Light>());
    let sun_metrics = outcome.values.get("sun.metrics").and_then(|v| v.get::<Metrics>());
    let text = notes::notes(&bake, &options, &written, sun, sun_metrics);
    let notes_path = out_dir.join(NOTES_FILE);
    if let Err(e) = crate::engine::cache::store::write_atomic(&notes_path, text.as_bytes()) {
        eprintln!("error: writing {}: {e}", notes_path.display());
        return Ok(ExitCode::from(1));
    }
    if let Some(c) = run_options.cache.as_ref().filter(|c| c.root().is_dir()) {
        if let Err(e) = c.evict() {
            eprintln!("warning: cache pruning: {e}");
        }
    }
    if !args.quiet {
        if args.verbose {
            progress::print_table(report);
        }
        outln!(
            "{}: {} nodes: {} computed, {} cached; {:.1} ms; {} files and {NOTES_FILE} written to {}",
            preset.name,
            report.nodes.len(),
            report.count(NodeStatus::Computed),
            report.count(NodeStatus::Cached),
            report.total_ms,
            written.len(),
            out_dir.display()
        );
    }
    // What became of the sun, every time (also under --quiet, on stderr, when light was moved
    // out of the files): the notes lead with the same paragraph.
    let statement = notes::sun_statement(&bake, &options, sun, sun_metrics);
    if sun.is_some_and(|s| s.solid_angle > 0.0) {
        eprintln!("{statement}");
    } else if !args.quiet {
        outln!("{statement}");
    }
    Ok(ExitCode::SUCCESS)
}
