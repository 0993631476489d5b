//! `ProbeSphere` against Blender itself, in the same run (issue 39): Debian's Blender 3.4.1
//! (installed by `.ci/run`) renders the lighting-estimation protocol's three spheres with Cycles
//! under the three CC0 maps, prepared as the protocol prepares them (256 x 128, its tonemap), and
//! hdrflow computes the same spheres from the same EXR files.
//!
//! - The scene is `bench/peers/blender_protocol_scene.py`, hdrflow's own script of the protocol's
//!   scene (the protocol's checkout cannot be fetched here); on the protocol's example map it
//!   renders what the protocol's own scripts render to 2.3e-6 (docs/src/guides/
//!   evaluation-protocol.md).
//! - Blender renders each sphere with seeds 0 and 1, at 10% (192 x 108) and 256 samples, without
//!   the denoiser (Debian's build has none). Over the pixels all three renders cover, the RMSE of
//!   hdrflow against the mean of the two seeds is divided by the RMSE of half their difference,
//!   the noise of that mean: 1 means hdrflow is as close to Blender as Blender's own noise allows.
//!   The bound per material is in [`BOUNDS`], with the ratios measured when it was set.
//! - The same spheres of the map turned by a quarter turn (`Rotate(yaw: 90)`) must exceed the
//!   bounds many times over, so the comparison can fail.
//! - The three prepared maps are written with three of `Save`'s lossless EXR compressions (Zip,
//!   Rle, Piz), so Blender's own OpenEXR reads each kind hdrflow writes.
//! - The wall time of both is printed, not asserted (speed belongs to the benchmarks).
//!
//! Blender runs with `--python-exit-code 1`, so an error in the script fails the test with its
//! traceback (Blender would otherwise exit 0). Without Blender the test skips visibly, and fails under `HDRFLOW_REQUIRE_BLENDER=1`.
//! `HDRFLOW_BLENDER` names the binary (default: `blender` on PATH).
//! Run: `cargo test --release --test probe_blender -- --nocapture` (prints the table).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::{run_command, Sandbox, MANIFEST_DIR};
use hdrflow::values::Image;

const REQUIRE: &str = "HDRFLOW_REQUIRE_BLENDER";
const TIMEOUT: Duration = Duration::from_secs(1200);
const MAPS: [&str; 3] = ["rooitou_park_1k", "st_fagans_interior_1k", "studio_small_03_1k"];
const MATERIALS: [(&str, &str); 3] = [("mirror", "Mirror"), ("matte_silver", "MatteSilver"), ("diffuse", "Diffuse")];
const PERCENT: usize = 10;
const BLENDER_SAMPLES: usize = 256;

/// Per material: the largest ratio of hdrflow's RMSE against Blender's noise, and the largest
/// relative difference of the mean over the covered pixels. Measured when set (2026-12-07, the
/// park, the interior, the studio; ProbeSphere version 2): mirror 1.43, 1.07, 1.02 and means
/// within 0.007%; matte silver 0.95, 1.47, 2.25 and -0.17 to -0.23% (the texel sum's known
/// deficit, docs/src/guides/evaluation-protocol.md); diffuse 1.11, 1.15, 1.15 and -0.03 to -0.15%. The studio's matte
/// silver is the one beyond the noise: at 10% a pixel spans about 2 degrees of normals, and its
/// softboxes' highlights, narrower than that, are shaded once per pixel where Cycles averages them
/// over the pixel (at 50% the pixel is five times smaller; the protocol's table there is within
/// 1.03 of the noise).
const BOUNDS: [(&str, f64, f64); 3] = [("mirror", 1.6, 0.002), ("matte_silver", 2.6, 0.006), ("diffuse", 1.3, 0.003)];

/// Blender, or `None` after a visible skip.
fn blender() -> Option<PathBuf> {
    if let Some(path) = std::env::var_os("HDRFLOW_BLENDER") {
        return Some(PathBuf::from(path));
    }
    let found = std::env::var_os("PATH")
        .and_then(|paths| std::env::split_paths(&paths).map(|p| p.join("blender")).find(|p| p.is_file()));
    if found.is_none() {
        common::skip(REQUIRE, "blender is not on PATH (Debian: apt-get install blender)");
    }
    found
}

fn load(path: &Path) -> Image {
    let bytes = common::read_file(path);
    hdrflow::formats::exr::decode(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The graph that prepares `map` as the protocol does, saves it for Blender, and renders the
/// three spheres of it and of it turned by 90 degrees. Each map is saved with another of
/// `Save`'s lossless EXR compressions, so Blender's OpenEXR reads each of them (a file it read
/// wrongly would light its spheres wrongly).
fn graph(map: &Path, name: &str) -> String {
    let (w, h) = (1920 * PERCENT / 100, 1080 * PERCENT / 100);
    let compression = match MAPS.iter().position(|&m| m == name) {
        Some(0) => "Zip",
        Some(1) => "Rle",
        _ => "Piz",
    };
    let mut nodes = format!(
        r#""env": LoadHdr(path: {}),
        "small": Resize(image: "env", width: 256, height: 128),
        "toned": ProtocolTonemap(image: "small"),
        "turned": Rotate(image: "toned", yaw: 90),
        "save_map": Save(input: "toned", path: "maps/{name}.exr", compression: {compression}),
"#,
        common::ron_path(map)
    );
    for (file, material) in MATERIALS {
        // The mirror's rays per pixel: enough that hdrflow's own sampling is below Blender's noise.
        let samples = if material == "Mirror" { 1024 } else { 64 };
        for (prefix, env) in [("hdrflow", "toned"), ("turned", "turned")] {
            nodes += &format!(
                r#"        "{prefix}_{file}": ProbeSphere(env: "{env}", material: {material}, width: {w}, height: {h}, samples: {samples}),
        "save_{prefix}_{file}": Save(input: "{prefix}_{file}", path: "{prefix}/{name}/{file}.exr"),
"#
            );
        }
    }
    format!("(nodes: {{\n        {nodes}}})\n")
}

/// What one hdrflow sphere is against the two Blender seeds.
struct Comparison {
    ratio: f64,
    mean_difference: f64,
    covered: usize,
}

/// The RMSE of `ours` against the seeds' mean over the pixels all three cover (alpha > 0),
/// divided by the RMSE of half the seeds' difference; and the relative difference of the means.
fn compare(ours: &Image, seed0: &Image, seed1: &Image) -> Comparison {
    for img in [seed0, seed1] {
        assert_eq!((img.width, img.height, img.channels), (ours.width, ours.height, 4), "Blender's render size");
    }
    let (mut err, mut noise, mut sum_ours, mut sum_blender, mut covered) = (0.0, 0.0, 0.0, 0.0, 0usize);
    for ((a, b), c) in ours.data.chunks(4).zip(seed0.data.chunks(4)).zip(seed1.data.chunks(4)) {
        if a[3] <= 0.0 || b[3] <= 0.0 || c[3] <= 0.0 {
            continue;
        }
        covered += 1;
        for k in 0..3 {
            let (a, b, c) = (a[k] as f64, b[k] as f64, c[k] as f64);
            let mean = 0.5 * (b + c);
            err += (a - mean).powi(2);
            noise += (0.5 * (b - c)).powi(2);
            sum_ours += a;
            sum_blender += mean;
        }
    }
    assert!(covered > 1000, "the renders cover {covered} pixels in common");
    Comparison { ratio: (err / noise).sqrt(), mean_difference: sum_ours / sum_blender - 1.0, covered }
}

#[test]
fn probe_sphere_equals_blender_within_its_own_noise() {
    let Some(blender) = blender() else { return };
    let sb = Sandbox::new();
    let script = Path::new(MANIFEST_DIR).join("bench/peers/blender_protocol_scene.py");
    let mut failures = Vec::new();
    let (mut hdrflow_time, mut blender_time) = (Duration::ZERO, Duration::ZERO);
    println!("map | material | ratio to Blender's noise (bound) | mean against Blender's | turned 90 degrees");
    for name in MAPS {
        let map = common::real_map(&format!("{name}.hdr"));
        let g = sb.write(format!("{name}.ron"), graph(&map, name));
        let start = Instant::now();
        sb.run_ok(&g, &["--no-cache"]);
        hdrflow_time += start.elapsed();

        let exr = sb.out().join(format!("maps/{name}.exr"));
        let renders = sb.join(format!("blender/{name}"));
        let mut cmd = Command::new(&blender);
        cmd.args(["--background", "--factory-startup", "--python-exit-code", "1", "--python"])
            .arg(&script)
            .arg("--")
            .arg(&exr)
            .arg(&renders);
        cmd.args([
            PERCENT.to_string(),
            BLENDER_SAMPLES.to_string(),
            "0,1".into(),
            "mirror,matte_silver,diffuse".into(),
        ]);
        let start = Instant::now();
        let out = run_command(cmd, TIMEOUT);
        blender_time += start.elapsed();
        out.assert_success();
        for line in out.stdout.lines().filter(|l| l.starts_with("blender_protocol_scene:")) {
            println!("{line}");
        }

        for (file, _) in MATERIALS {
            let seed0 = load(&renders.join(format!("seed0/{file}.exr")));
            let seed1 = load(&renders.join(format!("seed1/{file}.exr")));
            let ours = compare(&load(&sb.out().join(format!("hdrflow/{name}/{file}.exr"))), &seed0, &seed1);
            let turned = compare(&load(&sb.out().join(format!("turned/{name}/{file}.exr"))), &seed0, &seed1);
            let &(_, bound, mean_bound) = BOUNDS.iter().find(|b| b.0 == file).expect("a bound per material");
            println!(
                "{name} | {file} | {:.3} ({bound}) | {:+.3}% | {:.1} ({} px)",
                ours.ratio,
                100.0 * ours.mean_difference,
                turned.ratio,
                ours.covered
            );
            if ours.ratio.is_nan() || ours.ratio > bound {
                failures.push(format!("{name} {file}: hdrflow is {:.3} times Blender's noise from it", ours.ratio));
            }
            if ours.mean_difference.is_nan() || ours.mean_difference.abs() > mean_bound {
                failures.push(format!("{name} {file}: the mean differs by {:+.4}", ours.mean_difference));
            }
            if turned.ratio.is_nan() || turned.ratio <= 4.0 * bound {
                failures.push(format!("{name} {file}: the turned map is only {:.3} from Blender", turned.ratio));
            }
        }
    }
    println!(
        "wall time: hdrflow {:.1} s (the maps and 18 spheres), Blender {:.1} s (18 renders at {BLENDER_SAMPLES} samples)",
        hdrflow_time.as_secs_f64(),
        blender_time.as_secs_f64()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
