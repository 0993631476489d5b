//! `hdrflow bake MAP --for ENGINE` end to end: what it writes on a tiny map (the files, named as
//! the engine names them, a white furnace in the KTX2 read back by the `ktx2` crate, the Khronos
//! LUTs read back by the `image` crate, the README.txt and its engine code: Bevy's intensity, the
//! Khronos sun's colour, three.js's lines those of the render test's page), `--print-pipeline`,
//! `--sun keep`, where it writes without `--out` (`out/bake/ENGINE`), and the bad inputs it refuses
//! with a message that says what to do: an unknown engine, a map that is not 2:1, a size the engine
//! refuses, NaN and infinite texels (and `--sanitize`), a folder holding another engine's bake.

mod common;

use std::path::Path;

use common::{run_hdrflow, Sandbox, MANIFEST_DIR};
use hdrflow::formats::packed_float::decode_rgb9e5;
use hdrflow::values::Image;

/// Writes `img` as a PFM file at `path`.
fn write_pfm(path: &Path, img: &Image) -> String {
    common::write_file(path, hdrflow::formats::pfm::encode(img));
    path.to_str().unwrap().to_string()
}

fn bake(sb: &Sandbox, args: &[&str]) -> common::Output {
    let (out, cache) = (sb.out(), sb.cache());
    let mut all: Vec<&str> = vec!["bake"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", out.to_str().unwrap(), "--cache-dir", cache.to_str().unwrap()]);
    run_hdrflow(all)
}

#[test]
fn an_unknown_engine_is_refused_with_the_list_of_engines() {
    let sb = Sandbox::new();
    bake(&sb, &["builtin:sky", "--for", "unity"]).assert_code(2).assert_stderr_contains(
        "--for \"unity\": no such engine; hdrflow bake writes for babylon, bevy, filament, gltf, khronos, playcanvas, three",
    );
    bake(&sb, &["builtin:sky", "--for", "babylonjs"]).assert_code(2).assert_stderr_contains(
        "--for \"babylonjs\": no such engine; did you mean \"babylon\"? hdrflow bake writes for babylon, bevy",
    );
    bake(&sb, &["builtin:sky", "--for", "filamnet"])
        .assert_code(2)
        .assert_stderr_contains("did you mean \"filament\"?");
}

#[test]
fn a_map_that_is_not_two_to_one_names_the_shape_and_the_conversion() {
    let sb = Sandbox::new();
    let square = write_pfm(&sb.join("probe.pfm"), &Image::new(32, 32, 3));
    let o = bake(&sb, &[&square, "--for", "bevy"]);
    o.assert_code(2)
        .assert_stderr_contains("is 32x32, not a 2:1 lat-long (equirectangular) map")
        .assert_stderr_contains("an angular probe with AngularToLatLong, a mirror ball with MirrorBallToLatLong");
    assert!(!sb.out().exists(), "nothing ran\n{}", o.describe());
}

#[test]
fn a_size_filament_cannot_use_is_refused_with_cmgens_rule() {
    let sb = Sandbox::new();
    bake(&sb, &["builtin:constant", "--for", "filament", "--set", "spec.size=48"])
        .assert_code(2)
        .assert_stderr_contains("--for filament: a cube size of 48 is refused")
        .assert_stderr_contains("\"output size must be a power of two\"); use 32 or 64");
}

#[test]
fn nan_and_infinite_texels_are_counted_and_sanitize_replaces_them() {
    let sb = Sandbox::new();
    let mut img = Image::from_fn_rgb(32, 16, |_, _| [1.0, 1.0, 1.0]);
    img.pixel_mut(3, 4)[0] = f32::NAN;
    img.pixel_mut(5, 4)[1] = f32::NAN;
    img.pixel_mut(7, 9)[2] = f32::INFINITY;
    img.pixel_mut(8, 9)[0] = f32::NEG_INFINITY;
    let map = write_pfm(&sb.join("holes.pfm"), &img);
    bake(&sb, &[&map, "--for", "three"])
        .assert_code(1)
        .assert_stderr_contains("4 texels are NaN or infinite (the first at (3, 4): NaN): pass --sanitize");
    bake(&sb, &[&map, "--for", "three", "--sanitize"])
        .assert_success()
        .assert_stderr_contains("replaced 4 NaN or infinite texels (the first at (3, 4): NaN)");
}

/// A constant map baked for Bevy at draft quality: the two KTX2 files and the sun's JSON, named
/// as Bevy's assets are (the map's stem first), the specular chain down to 1x1 (128: 8 levels)
/// with every texel 1 (a white furnace, read back by the independent `ktx2` crate), and the
/// README's loading code naming them. `--sun keep` leaves the sun's file out.
#[test]
fn a_bevy_bake_writes_what_bevy_loads() {
    let sb = Sandbox::new();
    let o = bake(&sb, &["builtin:constant", "--for", "bevy", "--quality", "draft"]);
    // A 64 x 32 map holds 16 texels across a face: the draft chain's 128 is said to be 8x that.
    o.assert_success().assert_stdout_contains("bevy: ").assert_stderr_contains(
        "warning: builtin:constant is 64x32: small for --for bevy at --quality draft, whose cube faces are 128 texels",
    );
    o.assert_stderr_contains("upsampled 8x").assert_stderr_contains("--set spec.size=16");
    let out = sb.out();
    let names: Vec<String> = common::files_under(&out).iter().map(|f| f.display().to_string()).collect();
    assert_eq!(
        names,
        ["README.txt", "constant_diffuse_rgb9e5_zstd.ktx2", "constant_specular_rgb9e5_zstd.ktx2", "constant_sun.json"]
    );
    let bytes = std::fs::read(out.join("constant_specular_rgb9e5_zstd.ktx2")).unwrap();
    let reader = ktx2::Reader::new(&bytes[..]).expect("the ktx2 crate reads it");
    let header = reader.header();
    assert_eq!((header.pixel_width, header.face_count, header.level_count), (128, 6, 8));
    assert_eq!(header.format, Some(ktx2::Format::E5B9G9R9_UFLOAT_PACK32));
    assert_eq!(header.supercompression_scheme, Some(ktx2::SupercompressionScheme::Zstandard));
    for (k, level) in reader.levels().enumerate() {
        let raw = zstd::stream::decode_all(level.data).expect("each level is one zstd frame");
        assert_eq!(raw.len(), 6 * 4 * (128usize >> k).pow(2), "level {k}: 6 faces of 4-byte texels");
        let texels = raw.chunks_exact(4).map(|b| decode_rgb9e5(u32::from_le_bytes([b[0], b[1], b[2], b[3]])));
        // rgb9e5 holds 1 exactly; the bake's own error is below 2e-3.
        assert!(texels.flatten().all(|v| (v - 1.0).abs() < 2e-3), "level {k} is not white");
    }
    let readme = std::fs::read_to_string(out.join("README.txt")).unwrap();
    assert!(readme.contains("asset_server.load(\"environment_maps/constant_specular_rgb9e5_zstd.ktx2\")"), "{readme}");
    assert!(readme.contains("Sun: none found"), "a constant map has no sun:\n{readme}");
    // Bevy shows exposure x intensity x the map; the default camera's exposure is 2^-9.7 / 1.2
    // (bevy_camera's Exposure::BLENDER). The render test renders with exposure x intensity = 1
    // (clients/bevy: intensity 1, ev100 = -log2(1.2)): the README's intensity gives the same 1.
    let intensity: f64 = readme
        .lines()
        .find_map(|l| l.trim().strip_prefix("intensity: "))
        .and_then(|v| v.trim_end_matches(',').parse().ok())
        .unwrap_or_else(|| panic!("no intensity:\n{readme}"));
    let default_exposure = (-9.7f64).exp2() / 1.2;
    assert!((intensity * default_exposure - 1.0).abs() < 1e-6, "{intensity}");

    let sb = Sandbox::new();
    bake(&sb, &["builtin:constant", "--for", "bevy", "--quality", "draft", "--sun", "keep"]).assert_success();
    assert!(!sb.out().join("constant_sun.json").exists());
    assert!(sb.out().join("constant_specular_rgb9e5_zstd.ktx2").exists());
}

/// A draft Khronos bake of the sky writes both LUTs under the Sample Viewer's names, read back by
/// the `image` crate's PNG decoder: 16-bit RGB the size of the cube's level 0 (the sky is 512 x
/// 256: 64), `lut_ggx.png` with B = 0, `lut_charlie.png` with R = G = 0 and B = glTF-IBL-Sampler's
/// Charlie estimate at the texel centres (x = n.v, row 0 = roughness 0; 1024 samples, not the
/// quality's: the sampler's LUT count), clamped to 1 in the grazing corner; the README names
/// both and how the viewer reads them.
#[test]
fn a_khronos_bake_writes_both_luts_as_the_viewer_reads_them() {
    let sb = Sandbox::new();
    bake(&sb, &["builtin:sky", "--for", "khronos", "--quality", "draft", "-q"]).assert_success();
    let out = sb.out();
    let names: Vec<String> = common::files_under(&out).iter().map(|f| f.display().to_string()).collect();
    for want in ["lut_charlie.png", "lut_ggx.png", "ggx/specular.ktx2", "charlie/sheen.ktx2", "lambertian/diffuse.ktx2"]
    {
        assert!(names.iter().any(|n| n == want), "{want} not in {names:?}");
    }
    let read = |name: &str| match image::load_from_memory(&std::fs::read(out.join(name)).unwrap()).unwrap() {
        image::DynamicImage::ImageRgb16(img) => img,
        other => panic!("{name} is {:?}, not 16-bit RGB", other.color()),
    };
    let (ggx, charlie) = (read("lut_ggx.png"), read("lut_charlie.png"));
    assert_eq!((ggx.width(), ggx.height(), charlie.width(), charlie.height()), (64, 64, 64, 64));
    assert!(ggx.pixels().all(|p| p[2] == 0 && p[0] > 0));
    assert!(charlie.pixels().all(|p| p[0] == 0 && p[1] == 0));
    let pts = hdrflow::maths::brdf::ggx::points(hdrflow::maths::brdf::ggx::LobeSequence::Hammersley, 1024);
    let mut clamped = 0;
    for (x, y) in [(0, 0), (0, 3), (2, 10), (10, 20), (32, 32), (63, 5), (5, 63), (63, 63)] {
        let (nov, r) = ((x as f64 + 0.5) / 64.0, (y as f64 + 0.5) / 64.0);
        let want = hdrflow::maths::brdf::charlie::charlie_lut_texel(nov, r, &pts);
        clamped += usize::from(want > 1.0);
        let code = (want.clamp(0.0, 1.0) * 65535.0).round() as i32;
        let got = charlie.get_pixel(x, y)[2] as i32;
        assert!((got - code).abs() <= 1, "({x}, {y}): {got} vs {code} ({want})");
    }
    assert!(clamped > 0, "the grazing corner reaches 1");
    let readme = std::fs::read_to_string(out.join("README.txt")).unwrap();
    assert!(
        readme.contains("lut_charlie.png  Charlie LUT: sheen = prefiltered sheen * sheenColor * lut.b"),
        "{readme}"
    );
    // The sky's sun as a KHR_lights_punctual light: each channel of its colour in [0, 1] (the
    // schema's range), the largest 1, the magnitude in the intensity.
    let light = readme.lines().find(|l| l.contains("\"type\": \"directional\"")).expect("the sky has a sun");
    // "color": [R, G, B], "intensity": I }]
    let after = |key: &str| &light[light.find(key).unwrap_or_else(|| panic!("{key} in {light}")) + key.len()..];
    let color: Vec<f64> =
        after("\"color\": [").split(']').next().unwrap().split(", ").map(|v| v.parse().expect(light)).collect();
    let intensity: f64 = after("\"intensity\": ").split(' ').next().unwrap().parse().expect(light);
    assert_eq!(color.len(), 3, "{light}");
    assert!(color.iter().all(|c| (0.0..=1.0).contains(c)), "{light}");
    assert_eq!(color.iter().copied().fold(0.0, f64::max), 1.0, "{light}");
    assert!(intensity > 1.0, "{light}");
}

/// The README's three.js code is the code of the render test's page (tests/three_render.rs loads
/// the files with clients/three-web/render.js): every code line but the two naming the files is a
/// line of that page, and those two name the files the bake wrote.
#[test]
fn the_three_readme_code_is_the_render_pages_code() {
    let sb = Sandbox::new();
    bake(&sb, &["builtin:constant", "--for", "three", "--sun", "keep", "-q"]).assert_success();
    let readme = std::fs::read_to_string(sb.out().join("README.txt")).unwrap();
    let page = std::fs::read_to_string(Path::new(MANIFEST_DIR).join("clients/three-web/render.js")).unwrap();
    let page_lines: Vec<&str> = page.lines().map(str::trim).collect();
    let code = &readme[readme.find("// three.js r180").expect("the loading code")..];
    let mut checked = 0;
    for line in code.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")) {
        if let Some((_, file)) = line.strip_prefix("const ").and_then(|l| l.split_once("Url = '")) {
            let file = file.trim_end_matches("';");
            assert!(sb.out().join(file).is_file(), "{line}: no such file written");
        } else {
            assert!(page_lines.contains(&line), "not a line of clients/three-web/render.js: {line}");
            checked += 1;
        }
    }
    assert_eq!(checked, 8, "{code}");
}

/// Without `--out`, each engine's bake goes to `out/bake/ENGINE` (and says so), so two engines
/// never mix; a folder holding another engine's bake, or a README.txt no bake wrote, is refused
/// before anything runs, and baking the same engine again into its folder is fine.
#[test]
fn each_engine_bakes_into_its_own_folder_and_never_into_anothers() {
    let sb = Sandbox::new();
    let cache = sb.cache();
    let in_sandbox = |args: &[&str]| {
        let mut cmd =
            common::hdrflow_command(["bake"].iter().chain(args).chain(&["--cache-dir", cache.to_str().unwrap()]));
        cmd.current_dir(sb.path());
        common::run_command(cmd, common::RUN_TIMEOUT)
    };
    let three = sb.join("out/bake/three");
    in_sandbox(&["builtin:constant", "--for", "three", "--sun", "keep"])
        .assert_success()
        .assert_stdout_contains("files and README.txt written to out/bake/three");
    assert_eq!(
        common::files_under(&three).iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        ["README.txt", "constant_sh.json", "constant_three.hdr"]
    );
    let o = in_sandbox(&["builtin:constant", "--for", "bevy", "--out", "out/bake/three"]);
    o.assert_code(2).assert_stderr_contains(
        "out/bake/three holds a bake for three (its README.txt); a bake for bevy there would mix the two engines' \
         files and replace its notes: write it elsewhere with --out (the default, out/bake/bevy, keeps each engine \
         apart) or empty the folder first",
    );
    assert_eq!(common::files_under(&three).len(), 3, "nothing was written\n{}", o.describe());
    in_sandbox(&["builtin:constant", "--for", "three", "--sun", "keep", "-q"]).assert_success();

    let mine = sb.write("mine/README.txt", "My project's notes\n");
    in_sandbox(&["builtin:constant", "--for", "three", "--out", "mine"])
        .assert_code(2)
        .assert_stderr_contains("mine holds a README.txt that hdrflow bake did not write");
    assert_eq!(std::fs::read_to_string(mine).unwrap(), "My project's notes\n");
}

/// `--print-pipeline` prints the engine's pipeline and the overrides the bake applies, without
/// a map too (then builtin:sky), and runs nothing.
#[test]
fn print_pipeline_shows_the_pipeline_and_its_overrides() {
    let sb = Sandbox::new();
    let o = bake(&sb, &["--for", "filament", "--print-pipeline", "--yaw", "-90", "--quality", "high"]);
    o.assert_success()
        .assert_stdout_contains("// hdrflow bake builtin:sky --for filament: this pipeline, run with")
        .assert_stdout_contains("//   --set turned.yaw=-90.0")
        .assert_stdout_contains("//   --set spec.size=512")
        .assert_stdout_contains("//   --set spec.levels=6")
        .assert_stdout_contains("\"save_spec\": Save(input: \"spec\", path: \"sky_ibl.ktx\"");
    assert!(!sb.out().exists());
    // A chain size given with --set: the levels and the source cube follow it, the user's value wins.
    bake(&sb, &["--for", "bevy", "--print-pipeline", "--set", "spec.size=64"])
        .assert_success()
        .assert_stdout_contains("//   --set spec.levels=7\n")
        .assert_stdout_contains("//   --set cube.size=64\n")
        .assert_stdout_contains("//   --set spec.size=64\n");
}

/// The sun a user cannot lose (issue 36): on the park map `--sun extract` moves two thirds of the
/// light into the sun's file, and the bake says so every time, on stderr even under `--quiet`,
/// and the notes lead with it; the studio's softbox (13 degrees across) and the interior's lamp
/// (1.7% of the light) are not suns by SunExtract's rule and stay in the files, said too.
#[test]
fn the_bake_says_what_became_of_the_sun() {
    let maps = Path::new(MANIFEST_DIR).join("assets/maps");
    let readme_sun = |sb: &Sandbox| {
        let text = std::fs::read_to_string(sb.out().join("README.txt")).unwrap();
        let third = text.lines().nth(2).unwrap_or_default().to_string();
        (text, third)
    };
    let sb = Sandbox::new();
    let park = maps.join("rooitou_park_1k.hdr");
    let o = bake(&sb, &[park.to_str().unwrap(), "--for", "filament", "--quality", "draft", "--quiet"]);
    o.assert_success().assert_stderr_contains("Sun: 66% OF THE MAP'S LIGHT IS NOT IN THESE LIGHTING FILES");
    let (text, third) = readme_sun(&sb);
    assert!(third.starts_with("Sun: 66% OF THE MAP'S LIGHT") && third.contains("--sun keep"), "{text}");
    assert!(text.contains("\nThe sun:\n") && text.contains("LightManager::Builder(LightManager::Type::SUN)"), "{text}");

    for (map, said) in [
        ("studio_small_03_1k.hdr", "the brightest region (12.96 degrees across, 72.0% of the light) is not a sun"),
        ("st_fagans_interior_1k.hdr", "the brightest region (1.34 degrees across, 1.7% of the light) is not a sun"),
    ] {
        let sb = Sandbox::new();
        let path = maps.join(map);
        let o = bake(&sb, &[path.to_str().unwrap(), "--for", "filament", "--quality", "draft"]);
        o.assert_success().assert_stdout_contains(said).assert_stderr_contains("it stays in the map");
        let (text, third) = readme_sun(&sb);
        assert!(third.starts_with("Sun: none taken out") && third.contains(said), "{text}");
        assert!(!text.contains("The sun:"), "{text}");
        let sun: serde_json::Value =
            serde_json::from_slice(&std::fs::read(sb.out().join(map.replace(".hdr", "_sun.json"))).unwrap()).unwrap();
        assert_eq!(sun["solid_angle"], 0.0, "{map}: {sun}");
    }
}
