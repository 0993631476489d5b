//! `ProbeSphere` through the command line: the protocol's three spheres saved as files, their
//! coverage a disc of the radius the scene's camera predicts, the alpha of the RGBA image the mask,
//! and the bad inputs (a map that is not 2:1, a NaN texel) reported.

mod common;

use common::*;
use hdrflow::values::Image;

/// A grey sky, brighter above, with a warm patch behind the camera.
fn world(w: usize, h: usize) -> Image {
    Image::from_fn_rgb(w, h, |x, y| {
        let up = 1.0 - y as f32 / h as f32;
        let patch =
            if (x as i64 - (3 * w / 4) as i64).abs() < 4 && (y as i64 - (h / 2) as i64).abs() < 3 { 8.0 } else { 0.0 };
        [0.3 + up + patch, 0.3 + up + 0.5 * patch, 0.3 + up]
    })
}

fn load(path: &std::path::Path) -> Image {
    let ext = path.extension().unwrap().to_string_lossy().into_owned();
    hdrflow::formats::decode_by_extension(&read_file(path), &ext).unwrap()
}

#[test]
fn the_three_spheres_are_saved_with_their_coverage_as_alpha_and_mask() {
    let sb = Sandbox::new();
    sb.write("env.pfm", hdrflow::formats::pfm::encode(&world(64, 32)));
    let graph = sb.write(
        "p.ron",
        r#"(nodes: {
            "env": LoadHdr(path: "env.pfm"),
            "mirror": ProbeSphere(env: "env", material: Mirror, width: 192, height: 108, samples: 16),
            "silver": ProbeSphere(env: "env", material: MatteSilver, width: 192, height: 108, samples: 16),
            "diffuse": ProbeSphere(env: "env", material: Diffuse, width: 192, height: 108, samples: 16),
            "s1": Save(input: "mirror", path: "mirror.exr"),
            "s2": Save(input: "silver", path: "silver.exr"),
            "s3": Save(input: "diffuse", path: "diffuse.exr"),
            "s4": Save(input: "mirror.mask", path: "mask.pfm"),
        })"#,
    );
    sb.run_ok(&graph, &[]);
    let mask = load(&sb.out().join("mask.pfm"));
    assert_eq!((mask.width, mask.height, mask.channels), (192, 108, 1));
    // The camera's focal length is 85/36 of the width; the unit sphere at sqrt(260) spans
    // f / sqrt(259) px, and Blender's subdivided sphere is 0.987 to 0.998 of it.
    let radius = 192.0 * 85.0 / 36.0 / 259f64.sqrt();
    let area: f64 = mask.data.iter().map(|&a| a as f64).sum();
    let ratio = (area / (std::f64::consts::PI * radius * radius)).sqrt();
    assert!(ratio > 0.985 && ratio < 0.999, "coverage radius {ratio} of the unit sphere's");
    for name in ["mirror.exr", "silver.exr", "diffuse.exr"] {
        let img = load(&sb.out().join(name));
        assert_eq!((img.width, img.height, img.channels), (192, 108, 4), "{name}");
        let a = img.channel_index("A").unwrap();
        for (px, m) in img.data.chunks(4).zip(&mask.data) {
            assert_eq!(px[a], *m, "{name}: alpha is the mask");
            if *m == 0.0 {
                assert_eq!(&px[..3], &[0.0, 0.0, 0.0], "{name}: transparent off the sphere");
            } else if *m == 1.0 {
                assert!(px[..3].iter().all(|&v| v > 0.0 && v.is_finite()), "{name}: {px:?}");
            }
        }
    }
}

#[test]
fn a_map_that_is_not_two_to_one_warns_and_a_nan_texel_is_an_error() {
    let sb = Sandbox::new();
    sb.write("square.pfm", hdrflow::formats::pfm::encode(&world(32, 32)));
    let mut bad = world(64, 32);
    bad.data[100] = f32::NAN;
    sb.write("nan.pfm", hdrflow::formats::pfm::encode(&bad));
    let square = sb.write(
        "square.ron",
        r#"(nodes: {
            "env": LoadHdr(path: "square.pfm"),
            "p": ProbeSphere(env: "env", width: 48, height: 27, samples: 4),
            "s": Save(input: "p", path: "p.exr"),
        })"#,
    );
    let (out, _) = sb.run_ok(&square, &[]);
    out.assert_stderr_contains("not 2:1");
    let nan = sb.write(
        "nan.ron",
        r#"(nodes: {
            "env": LoadHdr(path: "nan.pfm"),
            "p": ProbeSphere(env: "env", width: 48, height: 27, samples: 4),
            "s": Save(input: "p", path: "p.exr"),
        })"#,
    );
    let (out, _) = sb.run(&nan, &[]);
    assert_ne!(out.code, Some(0), "{}", out.describe());
    out.assert_stderr_contains("NaN");
}

#[test]
fn out_of_range_sizes_are_rejected_before_running() {
    let sb = Sandbox::new();
    sb.write("env.pfm", hdrflow::formats::pfm::encode(&world(16, 8)));
    let graph = sb.write(
        "big.ron",
        r#"(nodes: {
            "env": LoadHdr(path: "env.pfm"),
            "p": ProbeSphere(env: "env", width: 0, samples: 100000),
            "s": Save(input: "p", path: "p.exr"),
        })"#,
    );
    let (out, _) = sb.run(&graph, &[]);
    assert_ne!(out.code, Some(0));
    out.assert_stderr_contains("width").assert_stderr_contains("samples");
}

/// The `.val` entries of a cache folder (two levels: `v1/<2 hex>/<key>.val`).
fn cache_entries(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "val") {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn a_later_process_reads_the_frames_plan_from_the_cache() {
    let sb = Sandbox::new();
    sb.write("a.pfm", hdrflow::formats::pfm::encode(&world(64, 32)));
    let mut other = world(64, 32);
    other.data.iter_mut().for_each(|v| *v *= 0.5);
    sb.write("b.pfm", hdrflow::formats::pfm::encode(&other));
    let graph = |map: &str| {
        format!(
            r#"(nodes: {{
                "env": LoadHdr(path: "{map}"),
                "mirror": ProbeSphere(env: "env", material: Mirror, width: 96, height: 54, samples: 8),
                "diffuse": ProbeSphere(env: "env", material: Diffuse, width: 96, height: 54, samples: 8),
                "s1": Save(input: "mirror", path: "mirror.exr"),
                "s2": Save(input: "diffuse", path: "diffuse.exr"),
            }})"#
        )
    };
    let first = sb.write("a.ron", graph("a.pfm"));
    sb.run_ok(&first, &[]);
    // The mirror's and the rough materials' stages, and the mirror's reads of a 64 x 32 map, are
    // entries of the cache.
    let entries = cache_entries(&sb.cache());
    let holding = |needle: &[u8]| {
        entries.iter().filter(|p| read_file(p).windows(needle.len()).any(|w| w == needle)).cloned().collect::<Vec<_>>()
    };
    let plans = holding(b"HFSTAGE1");
    assert_eq!(plans.len(), 2, "a mirror and a rough plan");
    assert_eq!(holding(b"HFREADS1").len(), 1, "the mirror's reads of one map size");
    // A plan read back gives what a plan made here gives: the other map with the cache, and
    // without it.
    let second = sb.write("b.ron", graph("b.pfm"));
    sb.run_ok(&second, &[]);
    let with_plans: Vec<Vec<u8>> = ["mirror.exr", "diffuse.exr"].iter().map(|n| read_file(&sb.out().join(n))).collect();
    sb.run_ok(&second, &["--no-cache"]);
    for (name, bytes) in ["mirror.exr", "diffuse.exr"].iter().zip(&with_plans) {
        assert_eq!(&read_file(&sb.out().join(name)), bytes, "{name}");
    }
    // The later process did read them: a stored plan altered (its first pixel's coverage set to
    // 0.5, the entry's checksum made again) shows in the next render of a new map.
    let mirror_plan = plans
        .iter()
        .find(|p| read_file(p).windows(6).any(|w| w == b"Mirror"))
        .expect("the mirror's plan entry")
        .clone();
    let mut entry = read_file(&mirror_plan);
    let at = entry.windows(8).position(|w| w == b"HFSTAGE1").expect("the stages") + 16;
    assert_eq!(entry[at], 0, "the first pixel is off the sphere");
    entry[at + 1..at + 9].copy_from_slice(&0.5f64.to_bits().to_le_bytes());
    let sum = *blake3::hash(&entry[52..]).as_bytes();
    entry[20..52].copy_from_slice(&sum);
    std::fs::write(&mirror_plan, &entry).expect("the altered entry");
    let mut third = world(64, 32);
    third.data.iter_mut().for_each(|v| *v *= 2.0);
    sb.write("c.pfm", hdrflow::formats::pfm::encode(&third));
    let c = sb.write("c.ron", graph("c.pfm"));
    sb.run_ok(&c, &[]);
    let mirror = load(&sb.out().join("mirror.exr"));
    let a = mirror.channel_index("A").expect("alpha");
    assert_eq!(mirror.data[a], 0.5, "the first pixel's coverage came from the stored plan");
}
