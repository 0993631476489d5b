//! `hdrflow bench`: run time against error for every relighting strategy and the peers, the
//! point targets, or `--glossy`. The binary's own subcommand, added to the library's command
//! line through `hdrflow::cli::ExtraCommands`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Subcommand};
use hdrflow::cli::ExtraCommands;
use hdrflow::Registry;

/// The subcommands the `hdrflow` binary adds to the library's.
#[derive(Subcommand)]
pub enum BinaryCommands {
    /// Benchmark run time against error for every relighting strategy and the peers.
    Bench(BenchArgs),
}

impl ExtraCommands for BinaryCommands {
    fn run(self, _: &Registry) -> ExitCode {
        match self {
            BinaryCommands::Bench(args) => bench(&args),
        }
    }
}

/// Writes `text` to stdout. A reader that has gone away (`hdrflow bench | head`) ends the
/// process quietly, as the library's commands do; any other write error is reported.
fn print_stdout(text: &str) {
    use std::io::Write as _;
    if let Err(e) = std::io::stdout().lock().write_all(text.as_bytes()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: writing to stdout: {e}");
        std::process::exit(1);
    }
}

#[derive(Args)]
pub struct BenchArgs {
    /// Output folder for results.csv, summary.md and the charts.
    #[arg(long, default_value = "bench/out")]
    out: PathBuf,
    /// Folder of the real environment maps that do not ship in assets/maps/ (Grace Cathedral;
    /// the park and the two interiors are read from assets/maps/); maps that are missing are
    /// skipped with a message.
    #[arg(long, default_value = "../shared/data/envmaps")]
    data: PathBuf,
    /// Sample counts (per image for shared samples, per pixel for per-pixel strategies).
    #[arg(long, value_delimiter = ',', default_value = "16,64,256,1024,4096")]
    counts: Vec<usize>,
    /// Sphere image size in pixels.
    #[arg(long, default_value_t = 128)]
    size: usize,
    /// Timed repetitions per point (after one warm-up run, on the first seed); the median is
    /// reported.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Independent seeds per stochastic point (1, 2, ..., N; scrambles for Sobol and Halton):
    /// each error is their mean, with a 95% confidence interval when N >= 2.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..))]
    seeds: u64,
    /// Only these maps (names: sky, grace, park, fagans, studio).
    #[arg(long, value_delimiter = ',')]
    maps: Vec<String>,
    /// Folder with the peers' scripts; they run when their Python dependencies are present.
    #[arg(long, default_value = "bench/peers")]
    peers: PathBuf,
    /// Do not run the peers.
    #[arg(long)]
    no_peers: bool,
    /// A quick run: counts 16,64,256, 3 repeats, 64x64 sphere, no peers, no targets (still
    /// --seeds seeds, 8 by default: 35 s to a minute on 2 cores).
    #[arg(long)]
    quick: bool,
    /// Measure only the point targets (relight speed, BuildCdf, decoding, the seed graph).
    #[arg(long)]
    targets_only: bool,
    /// Redraw the charts from this results.csv (into --out) without measuring anything.
    #[arg(long, value_name = "RESULTS_CSV")]
    replot: Option<PathBuf>,
    /// Measure GlossySphere's strategies and SunExtract instead (glossy.csv, glossy.md).
    #[arg(long)]
    glossy: bool,
    /// --glossy: the sphere's size in pixels (its exact reference costs pixels x texels).
    #[arg(long, default_value_t = 64)]
    glossy_size: usize,
    /// --glossy: samples per pixel.
    #[arg(long, value_delimiter = ',', default_value = "4,16,64,256")]
    glossy_spp: Vec<usize>,
    /// --glossy: Phong exponents.
    #[arg(long, value_delimiter = ',', default_value = "10,200")]
    exponents: Vec<f64>,
    /// Measure `hdrflow bake` instead: each preset's time and peak memory on 2048x1024 and
    /// 4096x2048 maps, and the Bevy chain's error per level for each estimator (bake.md).
    #[arg(long)]
    bake: bool,
    /// --bake: the map the sizes are made from.
    #[arg(long, default_value = "assets/maps/rooitou_park_1k.hdr")]
    bake_map: PathBuf,
    /// --bake: lat-long widths (heights are half).
    #[arg(long, value_delimiter = ',', default_value = "2048,4096")]
    bake_widths: Vec<usize>,
    /// --bake: texels per level the exact reference is evaluated at.
    #[arg(long, default_value_t = 600)]
    bake_texels: usize,
    /// --bake: only the chain errors, not the presets' bakes.
    #[arg(long)]
    bake_errors_only: bool,
    /// --bake: the chain errors of the 16k map's Khronos chain (4096 cube) at its sharp levels,
    /// scaled to a 1024 cube with the same lobe-to-texel ratios, instead of the Bevy chain's.
    #[arg(long)]
    bake_khronos_ratios: bool,
    /// --bake: the estimators compared (default: per chain), each `fis:N`, `plain:N`,
    /// `default:N` or `grouped:N:G`.
    #[arg(long, value_delimiter = ',')]
    bake_estimators: Vec<String>,
    /// --bake: only these presets (default: all; a 16384x8192 map's Khronos chain is 4096 per
    /// face, the sampler's half the map's height: its bake takes about 2 minutes on 2 cores).
    #[arg(long, value_delimiter = ',')]
    bake_presets: Vec<String>,
}

/// `--bake-estimators`: `fis:N`, `plain:N`, `default:N`, `grouped:N:G`.
fn parse_estimators(list: &[String]) -> Result<Vec<crate::bench::bake_error::Estimator>, String> {
    use crate::bench::bake_error::Estimator;
    list.iter()
        .map(|e| {
            let parts: Vec<&str> = e.split(':').collect();
            let num = |i: usize| -> Result<usize, String> {
                parts
                    .get(i)
                    .and_then(|p| p.parse().ok())
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("--bake-estimators: {e:?} needs a positive count"))
            };
            match parts[0] {
                "fis" => Ok(Estimator::Fis(num(1)?)),
                "plain" => Ok(Estimator::Plain(num(1)?)),
                "default" => Ok(Estimator::Default(num(1)?)),
                "grouped" => Ok(Estimator::Grouped(num(1)?, num(2)?)),
                _ => Err(format!("--bake-estimators: {e:?} is none of fis:N, plain:N, default:N, grouped:N:G")),
            }
        })
        .collect()
}

fn bench(args: &BenchArgs) -> ExitCode {
    use crate::bench::{map_path, BenchConfig, MapSpec};
    if args.bake {
        let config = crate::bench::bake::BakeBenchConfig {
            source: args.bake_map.clone(),
            widths: args.bake_widths.clone(),
            estimators: match parse_estimators(&args.bake_estimators) {
                Ok(e) if !e.is_empty() => e,
                Ok(_) if args.bake_khronos_ratios => crate::bench::bake::khronos_ratio_estimators(),
                Ok(_) => crate::bench::bake::default_estimators(),
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
            },
            khronos_ratios: args.bake_khronos_ratios,
            texels_per_level: args.bake_texels,
            errors_only: args.bake_errors_only,
            presets: args.bake_presets.clone(),
            out_dir: args.out.clone(),
        };
        eprintln!("hdrflow bench --bake on {} threads", rayon::current_num_threads());
        return finish(crate::bench::bake::run(&config, &|line| eprintln!("{line}")), |md| {
            format!("{md}wrote {}/bake.md\n", args.out.display())
        });
    }
    let candidates = [
        ("sky", "builtin:sky".to_string(), false),
        ("grace", map_path(&args.data, "grace_latlong.exr").display().to_string(), true),
        ("park", map_path(&args.data, "rooitou_park_1k.hdr").display().to_string(), false),
        ("fagans", map_path(&args.data, "st_fagans_interior_1k.hdr").display().to_string(), false),
        ("studio", map_path(&args.data, "studio_small_03_1k.hdr").display().to_string(), false),
    ];
    let mut maps = Vec::new();
    for (name, source, flip) in candidates {
        if !args.maps.is_empty() && !args.maps.iter().any(|m| m == name) {
            continue;
        }
        if !source.starts_with("builtin:") && !std::path::Path::new(&source).is_file() {
            eprintln!("SKIPPED map {name}: {source} not found");
            continue;
        }
        maps.push(MapSpec { name: name.to_string(), source, flip_vertical: flip });
    }
    if maps.is_empty() {
        eprintln!("error: no map to benchmark");
        return ExitCode::from(2);
    }
    if args.glossy {
        let config = crate::bench::glossy::GlossyBenchConfig {
            maps,
            spp: args.glossy_spp.clone(),
            exponents: args.exponents.clone(),
            size: args.glossy_size,
            repeats: if args.quick { 1 } else { args.repeats },
            seed: 1,
            out_dir: args.out.clone(),
        };
        eprintln!("hdrflow bench --glossy on {} threads", rayon::current_num_threads());
        return finish(crate::bench::glossy::run(&config, &|line| eprintln!("{line}")), |rows| {
            format!("{} points; wrote {}/glossy.csv and glossy.md\n", rows.len(), args.out.display())
        });
    }
    let config = BenchConfig {
        maps,
        counts: if args.quick { vec![16, 64, 256] } else { args.counts.clone() },
        size: if args.quick { 64 } else { args.size },
        repeats: if args.quick { 3 } else { args.repeats },
        albedo: 0.8,
        view: (90.0, 90.0),
        seed: 1,
        seeds: args.seeds as usize,
        out_dir: args.out.clone(),
        peers_dir: (!args.no_peers && !args.quick).then(|| args.peers.clone()),
    };
    if let Some(csv) = &args.replot {
        return finish(crate::bench::replot(&config, csv), |n| {
            format!("redrew {n} charts into {}\n", args.out.display())
        });
    }
    eprintln!(
        "hdrflow bench on {} threads; {} seed{} per stochastic point (seeds {} to {}){}",
        rayon::current_num_threads(),
        config.seeds,
        if config.seeds == 1 { "" } else { "s" },
        config.seed,
        config.seed + config.seeds as u64 - 1,
        if args.quick { "; --quick: counts 16,64,256, 64x64 sphere, 3 repeats, no peers, no targets" } else { "" }
    );
    if !args.quick {
        let peers = (!args.no_peers).then_some(args.peers.as_path());
        match crate::bench::targets::measure(&args.data, peers, config.repeats, &|line| eprintln!("{line}")) {
            Ok(targets) => {
                let md = crate::bench::targets::markdown(&targets);
                print_stdout(&md);
                let path = args.out.join("targets.md");
                if let Err(e) = std::fs::create_dir_all(&args.out)
                    .and_then(|_| hdrflow::engine::cache::store::write_atomic(&path, md.as_bytes()))
                {
                    eprintln!("error: writing {}: {e}", path.display());
                    return ExitCode::from(1);
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        }
        if args.targets_only {
            return ExitCode::SUCCESS;
        }
    }
    finish(crate::bench::run(&config, &|line| eprintln!("{line}")), |rows| {
        format!(
            "{} points; wrote {}/results.csv, summary.md and time_error_*.png/.svg\n",
            rows.len(),
            args.out.display()
        )
    })
}

/// How a measurement ends the command: on success `done(result)` on stdout and exit status 0,
/// on failure the error on stderr and status 1.
fn finish<T>(result: Result<T, String>, done: impl FnOnce(T) -> String) -> ExitCode {
    match result {
        Ok(value) => {
            print_stdout(&done(value));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::error::ErrorKind;
    use clap::Subcommand as _;

    /// The kind of error clap gives for `hdrflow ARGS...` over the binary's subcommands, and its
    /// message.
    fn parse_error(args: &[&str]) -> (ErrorKind, String) {
        let cli = super::BinaryCommands::augment_subcommands(clap::Command::new("hdrflow"));
        match cli.try_get_matches_from(std::iter::once("hdrflow").chain(args.iter().copied())) {
            Ok(_) => panic!("{args:?} parsed"),
            Err(e) => (e.kind(), e.to_string()),
        }
    }

    #[test]
    fn argument_errors() {
        let (kind, msg) = parse_error(&["bench", "--seeds", "0"]);
        assert_eq!(kind, ErrorKind::ValueValidation);
        assert!(msg.contains("--seeds"), "{msg}");
        assert_eq!(parse_error(&["bench", "--counts", "16,x"]).0, ErrorKind::ValueValidation);
        assert_eq!(parse_error(&["bench", "--size", "-3"]).0, ErrorKind::UnknownArgument);
    }
}
