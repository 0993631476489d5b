//! End-to-end tests of the `hdrflow` command line: runs, the cache, `--set`, `--target`, `plan`,
//! `dot`, `ops`, concurrency, determinism across `--jobs`, hostile and real input files, exit codes.
//!
//! Every test has its own sandbox (pipeline files, inputs, `--out`, `--cache-dir`); images are
//! tiny (`Constant` 64x32 or hand-written files) except where real data is the point.

mod common;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use common::{
    assert_statuses, files_under, hdrflow_command, read_file, ron_path, run_command, run_hdrflow, spawn, Output,
    Sandbox, RUN_TIMEOUT,
};
use hdrflow::formats::{pfm, rgbe};
use hdrflow::values::Image;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// A smooth RGB test image with distinct, positive values in every channel and pixel.
fn gradient(w: usize, h: usize, offset: f32) -> Image {
    Image::from_fn_rgb(w, h, |x, y| {
        let t = (y * w + x) as f32;
        [
            offset + 0.125 + 0.37 * t,
            offset + 1.5 * 2f32.powi((x % 7) as i32 - 3) + 0.01 * y as f32,
            offset + 100.0 / (1.0 + t),
        ]
    })
}

#[track_caller]
fn decode_pfm(path: &Path) -> Image {
    let bytes = read_file(path);
    pfm::decode(&bytes).unwrap_or_else(|e| panic!("{} does not decode as PFM: {e}", path.display()))
}

#[track_caller]
fn assert_all_close(img: &Image, want: &[f32], tol: f32, what: &str) {
    assert_eq!(img.channels, want.len(), "{what}: channel count");
    for (i, px) in img.data.chunks_exact(img.channels).enumerate() {
        for (c, (&got, &w)) in px.iter().zip(want).enumerate() {
            assert!((got - w).abs() <= tol * w.abs().max(1.0), "{what}: pixel {i} channel {c} is {got}, expected {w}");
        }
    }
}

/// Asserts both folders hold the same files with the same bytes; returns how many.
#[track_caller]
fn assert_same_files(a: &Path, b: &Path) -> usize {
    let fa = files_under(a);
    let fb = files_under(b);
    assert_eq!(fa, fb, "the two output folders hold different files");
    for f in &fa {
        let (x, y) = (read_file(&a.join(f)), read_file(&b.join(f)));
        assert!(x == y, "{} differs ({} vs {} bytes)", f.display(), x.len(), y.len());
    }
    fa.len()
}

/// Luminance of linear RGB with Rec.709 weights (the `Luminance` default), in f32 like the op.
fn rec709(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// Flips the last byte of every file under `dir`; returns how many files were touched.
fn corrupt_every_file(dir: &Path) -> usize {
    let files = files_under(dir);
    for f in &files {
        let path = dir.join(f);
        let mut bytes = read_file(&path);
        if let Some(last) = bytes.last_mut() {
            *last ^= 0xff;
        }
        std::fs::write(&path, &bytes).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
    }
    files.len()
}

// The branchy pipeline of the `--set` test: env -> exp -> lum -> save, env -> flip -> save2.
const BRANCHES: &str = r#"(
    nodes: {
        "env":   Constant(width: 64, height: 32, color: (0.25, 0.5, 1.0)),
        "exp":   Exposure(image: "env", stops: 1.0),
        "lum":   Luminance(image: "exp"),
        "save":  Save(input: "lum", path: "lum.pfm"),
        "flip":  FlipVertical(image: "env"),
        "save2": Save(input: "flip", path: "flip.pfm"),
    },
)
"#;

// A small chain with a scalar branch: env -> lum -> save.
const CHAIN: &str = r#"(
    nodes: {
        "env":  Constant(width: 64, height: 32, color: (1.0, 0.5, 0.25)),
        "lum":  Luminance(image: "env"),
        "save": Save(input: "lum", path: "lum.pfm"),
    },
)
"#;

/// `LoadHdr(path) -> Save(copy.pfm)`.
fn load_and_save(path: &str) -> String {
    format!(
        "(\n    nodes: {{\n        \"env\":  LoadHdr(path: {}),\n        \"save\": Save(input: \"env\", path: \"copy.pfm\"),\n    }},\n)\n",
        common::ron_str(path)
    )
}

// ---------------------------------------------------------------------------------------------
// Runs and the cache
// ---------------------------------------------------------------------------------------------

#[test]
fn example_pipeline_runs_and_a_second_run_is_served_from_the_cache() {
    let sb = Sandbox::new();
    let graph = Path::new("graphs/example.ron");

    let (_, r1) = sb.run_ok(graph, &[]);
    assert_statuses(&r1.status, &[("env", "computed"), ("lum", "computed"), ("save", "computed")], "first run");
    let exr_path = sb.out().join("luminance.exr");
    let exr = read_file(&exr_path);
    assert!(exr.starts_with(&[0x76, 0x2f, 0x31, 0x01]), "luminance.exr does not start with the OpenEXR magic");
    let img = hdrflow::formats::decode_by_extension(&exr, "exr").unwrap_or_else(|e| panic!("luminance.exr: {e}"));
    assert!(img.width > 0 && img.height > 0, "empty luminance.exr");
    assert!(img.data.iter().all(|v| v.is_finite() && *v >= 0.0), "luminance.exr has negative or non-finite values");

    let (out2, r2) = sb.run_ok(graph, &[]);
    let computed = r2.with_status("computed");
    assert!(computed.is_empty(), "second run computed {computed:?}; report {:#?}\n{}", r2.status, out2.describe());
    assert_eq!(r2.status_of("save"), "cached", "{:#?}", r2.status);
    assert_eq!(read_file(&exr_path), exr, "the second run changed luminance.exr");
    for (name, key) in &r1.key {
        assert_eq!(r2.key_of(name), key.as_str(), "node {name}: key changed between identical runs");
    }
}

#[test]
fn set_recomputes_exactly_the_changed_node_and_its_dependents() {
    let sb = Sandbox::new();
    let graph = sb.write("branches.ron", BRANCHES);

    let (_, cold) = sb.run_ok(&graph, &[]);
    for name in ["env", "exp", "lum", "save", "flip", "save2"] {
        assert_eq!(cold.status_of(name), "computed", "cold run: {:#?}", cold.status);
    }
    let y1 = rec709([0.5, 1.0, 2.0]);
    assert_all_close(&decode_pfm(&sb.out().join("lum.pfm")), &[y1], 1e-6, "lum.pfm at 1 stop");
    let flip_before = read_file(&sb.out().join("flip.pfm"));

    let (out, warm) = sb.run_ok(&graph, &["--set", "exp.stops=2.0"]);
    let ctx = out.describe();
    assert_statuses(
        &warm.status,
        &[("exp", "computed"), ("lum", "computed"), ("save", "computed"), ("env", "cached"), ("save2", "cached")],
        &ctx,
    );
    // `flip` is needed only by `save2`, which comes from the cache: the scheduler reports such a
    // node as "not needed" (documented in NodeStatus::Skipped). Either way it must not be computed.
    assert!(
        matches!(warm.status_of("flip"), "cached" | "not needed"),
        "flip was recomputed although nothing it depends on changed: {:#?}\n{ctx}",
        warm.status
    );
    assert_ne!(warm.key_of("exp"), cold.key_of("exp"), "exp's key ignores its stops");
    assert_eq!(warm.key_of("env"), cold.key_of("env"));
    assert_eq!(warm.key_of("save2"), cold.key_of("save2"));
    let y2 = rec709([1.0, 2.0, 4.0]);
    assert_all_close(&decode_pfm(&sb.out().join("lum.pfm")), &[y2], 1e-6, "lum.pfm at 2 stops");
    assert_eq!(read_file(&sb.out().join("flip.pfm")), flip_before, "flip.pfm changed");

    // Back to 1 stop, written as an integer: `1` and `1.0` have the same key, so everything is
    // cached, and the cached file value is put back in the output folder.
    let (out, back) = sb.run_ok(&graph, &["--set", "exp.stops=1"]);
    assert!(
        back.with_status("computed").is_empty(),
        "stops=1 after stops=1.0 recomputed: {:#?}\n{}",
        back.status,
        out.describe()
    );
    assert_eq!(back.key_of("exp"), cold.key_of("exp"), "`1` and `1.0` give different keys");
    assert_all_close(&decode_pfm(&sb.out().join("lum.pfm")), &[y1], 1e-6, "lum.pfm back at 1 stop");
}

#[test]
fn a_same_size_edit_with_its_mtime_restored_is_noticed() {
    let sb = Sandbox::new();
    let before = gradient(8, 4, 0.0);
    let after = gradient(8, 4, 100.0);
    let input = sb.write("in.pfm", pfm::encode(&before));
    let graph = sb.write("load.ron", load_and_save("in.pfm"));

    let (_, r1) = sb.run_ok(&graph, &[]);
    assert_eq!(r1.status_of("env"), "computed");
    assert_eq!(decode_pfm(&sb.out().join("copy.pfm")), before);

    let meta = std::fs::metadata(&input).expect("input metadata");
    let (mtime, len): (SystemTime, u64) = (meta.modified().expect("mtime"), meta.len());
    let new_bytes = pfm::encode(&after);
    assert_eq!(new_bytes.len() as u64, len, "test bug: the edit must keep the size");
    std::fs::write(&input, &new_bytes).expect("overwrite input");
    let f = std::fs::File::options().write(true).open(&input).expect("open input");
    f.set_modified(mtime).expect("restore mtime");
    drop(f);
    let meta = std::fs::metadata(&input).expect("input metadata");
    assert_eq!(meta.modified().expect("mtime"), mtime, "test bug: mtime not restored");
    assert_eq!(meta.len(), len);

    let (out, r2) = sb.run_ok(&graph, &[]);
    assert_eq!(
        r2.status_of("env"),
        "computed",
        "the edited input was not reloaded: {:#?}\n{}",
        r2.status,
        out.describe()
    );
    assert_eq!(r2.status_of("save"), "computed", "{:#?}", r2.status);
    assert_ne!(r2.key_of("env"), r1.key_of("env"));
    let copy = decode_pfm(&sb.out().join("copy.pfm"));
    assert_ne!(copy, before, "the output still holds the old content");
    assert_eq!(copy, after);
}

#[test]
fn moving_an_input_file_keeps_its_key() {
    let sb = Sandbox::new();
    let img = gradient(8, 4, 0.0);
    sb.write("a/in.pfm", pfm::encode(&img));
    let graph = sb.write("load.ron", load_and_save("a/in.pfm"));

    let (_, r1) = sb.run_ok(&graph, &[]);
    assert_eq!(r1.status_of("env"), "computed");
    let key = r1.key_of("env").to_string();
    assert!(!key.is_empty(), "no key for env");

    std::fs::create_dir_all(sb.join("b")).expect("mkdir b");
    std::fs::rename(sb.join("a/in.pfm"), sb.join("b/moved.pfm")).expect("move the input");
    // A path given with --set is relative to the working folder: give it absolute.
    let set = format!("env.path={}", sb.join("b/moved.pfm").display());
    let set = set.as_str();

    let (out, r2) = sb.run_ok(&graph, &["--set", set]);
    assert_eq!(r2.key_of("env"), key, "moving the file changed LoadHdr's key\n{}", out.describe());
    assert_eq!(r2.status_of("save"), "cached", "{:#?}\n{}", r2.status, out.describe());
    assert!(r2.with_status("computed").is_empty(), "{:#?}", r2.status);

    let (_, r3) = sb.run_ok(&graph, &["--set", set, "--target", "env"]);
    assert_eq!(r3.status_of("env"), "cached", "{:#?}", r3.status);
    assert_eq!(r3.key_of("env"), key);
    assert_eq!(decode_pfm(&sb.out().join("copy.pfm")), img);
}

#[test]
fn target_runs_only_what_the_target_needs() {
    let sb = Sandbox::new();
    let graph = sb.write("chain.ron", CHAIN);
    let (out, r) = sb.run_ok(&graph, &["--target", "lum"]);
    assert_statuses(&r.status, &[("env", "computed"), ("lum", "computed"), ("save", "not needed")], &out.describe());
    assert_eq!(r.key_of("save"), "", "a node that is not needed has no key in the report");
    let written = files_under(&sb.out());
    assert!(written.is_empty(), "--target lum wrote {written:?}");
}

#[test]
fn plan_shows_compute_cached_and_not_needed_before_and_after_a_run() {
    let sb = Sandbox::new();
    let graph = sb.write("chain.ron", CHAIN);

    let p = sb.plan(&graph, &[]);
    assert_statuses(&p, &[("env", "computed"), ("lum", "computed"), ("save", "computed")], "plan before");
    let p = sb.plan(&graph, &["--target", "lum"]);
    assert_statuses(
        &p,
        &[("env", "computed"), ("lum", "computed"), ("save", "not needed")],
        "plan --target lum before",
    );
    assert!(files_under(&sb.out()).is_empty(), "plan wrote outputs");
    assert!(files_under(&sb.cache()).is_empty(), "plan wrote to the cache");

    sb.run_ok(&graph, &[]);

    let p = sb.plan(&graph, &[]);
    assert_statuses(&p, &[("save", "cached"), ("lum", "not needed"), ("env", "not needed")], "plan after");
    let p = sb.plan(&graph, &["--target", "lum"]);
    assert_statuses(&p, &[("lum", "cached"), ("env", "not needed"), ("save", "not needed")], "plan --target lum after");
    let p = sb.plan(&graph, &["--set", "env.width=65"]);
    assert_statuses(&p, &[("env", "computed"), ("lum", "computed"), ("save", "computed")], "plan after an edit");
}

#[test]
fn corrupt_cache_entries_are_recomputed_with_a_warning() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "corrupt.ron",
        r#"(
    nodes: {
        "env":      Constant(width: 64, height: 32, color: (0.25, 0.5, 1.0)),
        "exp":      Exposure(image: "env", stops: 1.0),
        "lum":      Luminance(image: "exp"),
        "save_img": Save(input: "exp", path: "img.pfm"),
        "save_lum": Save(input: "lum", path: "lum.pfm"),
    },
)
"#,
    );
    let (out1, cache) = (sb.join("out1"), sb.cache());
    let (o, r1) = sb.run_in(&graph, &out1, &cache, &[]);
    o.assert_success();
    let r1 = r1.expect("report");
    assert_eq!(r1.with_status("computed").len(), 5, "{:#?}", r1.status);

    let corrupted = corrupt_every_file(&cache);
    assert!(corrupted >= 5, "expected a cache entry per node, found {corrupted} files: {:?}", files_under(&cache));

    let out2 = sb.join("out2");
    let (o, r2) = sb.run_in(&graph, &out2, &cache, &[]);
    o.assert_success().assert_stderr_contains("corrupt");
    let r2 = r2.expect("report");
    for name in ["env", "exp", "lum", "save_img", "save_lum"] {
        assert_eq!(r2.status_of(name), "computed", "{:#?}\n{}", r2.status, o.describe());
    }
    assert_eq!(assert_same_files(&out1, &out2), 2);

    // The bad entries were replaced: a third run is served from the cache without a warning.
    let (o, r3) = sb.run_in(&graph, &out2, &cache, &[]);
    o.assert_success();
    assert!(!o.stderr.contains("corrupt"), "entries still corrupt after recomputation\n{}", o.describe());
    assert!(r3.expect("report").with_status("computed").is_empty());
}

#[test]
fn two_runs_at_once_on_one_cache_and_one_output_folder() {
    let sb = Sandbox::new();
    let graph = sb.write(
        "concurrent.ron",
        r#"(
    nodes: {
        "env":       Constant(width: 512, height: 256, color: (0.5, 1.0, 2.0)),
        "exp":       Exposure(image: "env", stops: 1.0),
        "lum":       Luminance(image: "exp"),
        "flip":      FlipVertical(image: "exp"),
        "save_exp":  Save(input: "exp", path: "exp.pfm"),
        "save_lum":  Save(input: "lum", path: "lum.pfm"),
        "save_flip": Save(input: "flip", path: "flip.hdr"),
    },
)
"#,
    );
    let (out, cache) = (sb.out(), sb.cache());
    let (ra, rb) = (sb.next_report(), sb.next_report());
    let a = spawn(sb.run_command(&graph, &out, &cache, &ra, &[]));
    let b = spawn(sb.run_command(&graph, &out, &cache, &rb, &[]));
    let (oa, ob) = (a.wait(RUN_TIMEOUT), b.wait(RUN_TIMEOUT));
    oa.assert_success();
    ob.assert_success();
    common::read_report(&ra);
    common::read_report(&rb);

    let files = files_under(&out);
    assert_eq!(
        files,
        [PathBuf::from("exp.pfm"), PathBuf::from("flip.hdr"), PathBuf::from("lum.pfm")],
        "unexpected files (temporary files left behind?)"
    );
    let exp = decode_pfm(&out.join("exp.pfm"));
    assert_eq!((exp.width, exp.height), (512, 256));
    assert_all_close(&exp, &[1.0, 2.0, 4.0], 0.0, "exp.pfm");
    let lum = decode_pfm(&out.join("lum.pfm"));
    assert_all_close(&lum, &[rec709([1.0, 2.0, 4.0])], 1e-6, "lum.pfm");
    let flip = rgbe::decode(&read_file(&out.join("flip.hdr"))).unwrap_or_else(|e| panic!("flip.hdr: {e}"));
    assert_eq!((flip.width, flip.height), (512, 256));
    assert_all_close(&flip, &[1.0, 2.0, 4.0], 0.0, "flip.hdr (1, 2, 4 are exact in RGBE)");
    let stray: Vec<_> = files_under(&cache).into_iter().filter(|f| f.to_string_lossy().contains(".tmp-")).collect();
    assert!(stray.is_empty(), "temporary files left in the cache: {stray:?}");

    // Whatever the interleaving, the cache is sound afterwards.
    let (o, r) = sb.run(&graph, &[]);
    o.assert_success();
    assert!(!o.stderr.contains("corrupt"), "{}", o.describe());
    assert!(!o.stderr.contains("warning"), "{}", o.describe());
    assert!(r.expect("report").with_status("computed").is_empty());
}

#[test]
fn jobs_1_and_jobs_2_give_byte_identical_outputs_for_the_seed_pipeline() {
    let sb = Sandbox::new();
    let graph = Path::new("graphs/seed.ron");
    let timeout = Duration::from_secs(600);
    let mut outputs = Vec::new();
    for jobs in ["1", "2"] {
        let out = sb.join(format!("out-jobs{jobs}"));
        let cache = sb.join(format!("cache-jobs{jobs}"));
        let report = sb.next_report();
        let o = run_command(
            sb.run_command(graph, &out, &cache, &report, &["--jobs", jobs, "--no-cache", "--quiet"]),
            timeout,
        );
        o.assert_success();
        assert!(files_under(&cache).is_empty(), "--no-cache wrote to the cache folder");
        outputs.push(out);
    }
    let n = assert_same_files(&outputs[0], &outputs[1]);
    assert!(n >= 20, "seed.ron wrote only {n} files");
}

// ---------------------------------------------------------------------------------------------
// dot and ops
// ---------------------------------------------------------------------------------------------

#[test]
fn dot_prints_a_digraph_with_labelled_edges() {
    let o = run_hdrflow(["dot", "graphs/example.ron"]);
    o.assert_success();
    assert!(o.stdout.trim_start().starts_with("digraph"), "{}", o.describe());
    o.assert_stdout_contains(r#""env" -> "lum" [label="image"];"#);
    o.assert_stdout_contains(r#""lum" -> "save" [label="input"];"#);
    assert!(o.stdout.trim_end().ends_with('}'), "{}", o.describe());

    let sb = Sandbox::new();
    let graph = sb.write("branches.ron", BRANCHES);
    let o = run_hdrflow([OsStr::new("dot"), graph.as_os_str()]);
    o.assert_success();
    for edge in
        [r#""env" -> "exp""#, r#""exp" -> "lum""#, r#""lum" -> "save""#, r#""env" -> "flip""#, r#""flip" -> "save2""#]
    {
        o.assert_stdout_contains(edge);
    }
    assert_eq!(o.stdout.matches(" -> \"").count(), 5, "expected exactly 5 edges\n{}", o.describe());
    assert!(files_under(sb.path()).iter().all(|f| f == Path::new("branches.ron")), "dot wrote files");
}

#[test]
fn ops_lists_operators_fields_and_builtin_maps() {
    let o = run_hdrflow(["ops"]);
    o.assert_success();
    for name in ["LoadHdr", "Luminance", "Save", "Exposure", "Constant", "FlipVertical", "BuildCdf"] {
        assert!(
            o.stdout.lines().any(|l| l.starts_with(&format!("{name} (v"))),
            "ops does not list {name}\n{}",
            o.describe()
        );
    }
    for field in ["path", "flip_vertical", "weights", "stops", "input", "exposure"] {
        assert!(
            o.stdout.lines().any(|l| l.trim_start().starts_with(&format!("{field} "))),
            "ops does not list field {field}\n{}",
            o.describe()
        );
    }
    o.assert_stdout_contains("Rec709 | Rec2020 | Mean | Max");
    o.assert_stdout_contains("builtin:");
    assert!(
        o.stdout.lines().any(|l| l.trim_start().starts_with("sky ") || l.trim() == "sky"),
        "the built-in map `sky` (used by graphs/example.ron) is not listed\n{}",
        o.describe()
    );

    let one = run_hdrflow(["ops", "luminance"]);
    one.assert_success().assert_stdout_contains("Luminance (v");
    assert!(!one.stdout.contains("LoadHdr (v"), "ops luminance listed other operators\n{}", one.describe());

    run_hdrflow(["ops", "NoSuchOperator"]).assert_code(2).assert_stderr_contains("LoadHdr");
}

// ---------------------------------------------------------------------------------------------
// Input files: hostile, round trips, real data
// ---------------------------------------------------------------------------------------------

/// Deterministic junk (xorshift64*).
fn junk(n: usize, seed: u64) -> Vec<u8> {
    let mut s = seed | 1;
    (0..n)
        .map(|_| {
            s ^= s >> 12;
            s ^= s << 25;
            s ^= s >> 27;
            (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8
        })
        .collect()
}

/// Runs `LoadHdr(name) -> Save` on a file and checks: exit 1, the file named in the error, no
/// panic, nothing written, fast.
#[track_caller]
fn assert_load_fails_cleanly(sb: &Sandbox, name: &str, also: &[&str]) -> Output {
    let graph = sb.write(format!("load_{name}.ron"), load_and_save(name));
    let out = sb.join(format!("out_{name}"));
    let (o, _) = sb.run_in(&graph, &out, &sb.cache(), &[]);
    o.assert_code(1).assert_stderr_contains(name);
    assert!(!o.stderr.contains("panicked"), "{name}: the loader panicked\n{}", o.describe());
    for s in also {
        assert!(o.stderr.to_lowercase().contains(&s.to_lowercase()), "{name}: stderr lacks {s:?}\n{}", o.describe());
    }
    assert!(o.elapsed < Duration::from_secs(5), "{name}: took {:?} to fail\n{}", o.elapsed, o.describe());
    assert!(files_under(&out).is_empty(), "{name}: outputs written");
    o
}

#[test]
fn hostile_input_files_fail_fast_with_an_error_naming_the_file() {
    let sb = Sandbox::new();
    let hdr_header = |h: u32, w: u32| format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    let with_tail = |mut head: Vec<u8>, tail: Vec<u8>| {
        head.extend(tail);
        head
    };

    // Claims 4e10 pixels (over the 2^28 limit) followed by 100 bytes.
    sb.write("huge.hdr", with_tail(hdr_header(200_000, 200_000), vec![0x80; 100]));
    assert_load_fails_cleanly(&sb, "huge.hdr", &[]);
    // Within the pixel limit, but 100 bytes cannot hold 16000 scanlines.
    sb.write("big_claim.hdr", with_tail(hdr_header(16_000, 16_000), junk(100, 1)));
    assert_load_fails_cleanly(&sb, "big_claim.hdr", &[]);
    // The same for PFM.
    sb.write("huge.pfm", with_tail(b"PF\n200000 200000\n-1.0\n".to_vec(), vec![0u8; 100]));
    assert_load_fails_cleanly(&sb, "huge.pfm", &[]);
    sb.write("big_claim.pfm", with_tail(b"PF\n16000 16000\n-1.0\n".to_vec(), junk(100, 2)));
    assert_load_fails_cleanly(&sb, "big_claim.pfm", &[]);
    // Garbage named .exr (first byte is not the OpenEXR magic's 0x76).
    let mut garbage = junk(4096, 3);
    garbage[0] = 0x00;
    sb.write("garbage.exr", garbage);
    assert_load_fails_cleanly(&sb, "garbage.exr", &[]);
    // Right size, wrong magic.
    sb.write("wrong_magic.hdr", with_tail(b"P6\n16 8\n255\n".to_vec(), junk(16 * 8 * 3, 4)));
    assert_load_fails_cleanly(&sb, "wrong_magic.hdr", &["magic"]);
    sb.write("wrong_magic.pfm", rgbe::encode(&gradient(8, 4, 0.0)));
    assert_load_fails_cleanly(&sb, "wrong_magic.pfm", &["magic"]);
    sb.write("pfm_named.exr", pfm::encode(&gradient(8, 4, 0.0)));
    assert_load_fails_cleanly(&sb, "pfm_named.exr", &[]);
    // A missing file: found by validation (exit 2), at its field, before anything runs.
    let graph = sb.write("load_missing.ron", load_and_save("does_not_exist.pfm"));
    let out = sb.join("out_missing");
    let (o, _) = sb.run_in(&graph, &out, &sb.cache(), &[]);
    o.assert_code(2)
        .assert_stderr_contains(r#"load_missing.ron:3:31: node "env": field "path": input file "does_not_exist.pfm""#);
    assert!(files_under(&out).is_empty(), "outputs written");
}

#[test]
fn loadhdr_round_trips_rgbe_within_its_precision() {
    let sb = Sandbox::new();
    // Width 16 uses new-style RLE scanlines, width 5 flat ones.
    let (wide, narrow) = (gradient(16, 8, 0.0), gradient(5, 3, 0.0));
    sb.write("wide.hdr", rgbe::encode(&wide));
    sb.write("narrow.hdr", rgbe::encode(&narrow));
    let graph = sb.write(
        "hdr.ron",
        r#"(
    nodes: {
        "wide":        LoadHdr(path: "wide.hdr"),
        "narrow":      LoadHdr(path: "narrow.hdr"),
        "save_wide":   Save(input: "wide", path: "wide.pfm"),
        "save_narrow": Save(input: "narrow", path: "narrow.pfm"),
    },
)
"#,
    );
    sb.run_ok(&graph, &[]);
    for (name, orig) in [("wide", &wide), ("narrow", &narrow)] {
        let read = decode_pfm(&sb.out().join(format!("{name}.pfm")));
        assert_eq!((read.width, read.height, read.channels), (orig.width, orig.height, 3), "{name}");
        for (i, (g, o)) in read.data.chunks_exact(3).zip(orig.data.chunks_exact(3)).enumerate() {
            // RGBE keeps 8 bits of mantissa relative to the pixel's largest channel (truncated).
            let max = o.iter().copied().fold(0f32, f32::max);
            for (c, (&got, &want)) in g.iter().zip(o).enumerate() {
                let err = (got - want).abs();
                let allowed = max / 128.0;
                assert!(
                    err <= allowed * 1.0001,
                    "{name}: pixel {i} channel {c}: {want} read back as {got} (error {err}, allowed {allowed})"
                );
            }
        }
    }
}

#[test]
fn loadhdr_round_trips_pfm_exactly_grey_and_flipped() {
    let sb = Sandbox::new();
    let rgb = gradient(9, 5, 0.0);
    let grey = Image::from_vec(6, 4, 1, (0..24).map(|i| 0.5 + i as f32 * 1.25).collect());
    sb.write("rgb.pfm", pfm::encode(&rgb));
    sb.write("grey.pfm", pfm::encode(&grey));
    let graph = sb.write(
        "pfm.ron",
        r#"(
    nodes: {
        "rgb":       LoadHdr(path: "rgb.pfm"),
        "grey":      LoadHdr(path: "grey.pfm"),
        "flipped":   LoadHdr(path: "rgb.pfm", flip_vertical: true),
        "save_rgb":  Save(input: "rgb", path: "rgb.pfm"),
        "save_grey": Save(input: "grey", path: "grey.pfm"),
        "save_flip": Save(input: "flipped", path: "flipped.pfm"),
    },
)
"#,
    );
    sb.run_ok(&graph, &[]);
    assert_eq!(decode_pfm(&sb.out().join("rgb.pfm")), rgb, "PFM round trip is not exact");
    let g = decode_pfm(&sb.out().join("grey.pfm"));
    assert_eq!((g.width, g.height, g.channels), (6, 4, 3), "a grey PFM loads as RGB");
    for (i, px) in g.data.chunks_exact(3).enumerate() {
        assert_eq!(px, [grey.data[i]; 3], "grey pixel {i}");
    }
    let f = decode_pfm(&sb.out().join("flipped.pfm"));
    assert_eq!((f.width, f.height), (9, 5));
    for y in 0..5 {
        for x in 0..9 {
            assert_eq!(f.pixel(x, y), rgb.pixel(x, 4 - y), "flip_vertical: pixel ({x}, {y})");
        }
    }
}

#[test]
fn loadhdr_round_trips_exr_exactly() {
    let sb = Sandbox::new();
    let img = gradient(12, 7, 0.0);
    let exr = hdrflow::formats::exr::encode(&img).expect("encoding the test EXR");
    sb.write("in.exr", exr);
    let graph = sb.write("exr.ron", load_and_save("in.exr"));
    sb.run_ok(&graph, &[]);
    let got = decode_pfm(&sb.out().join("copy.pfm"));
    assert_eq!((got.width, got.height, got.channels), (12, 7, 3));
    assert_eq!(got, img, "an f32 EXR does not round-trip exactly");
}

/// Per-channel maxima and means from ../shared/data/envmaps/SOURCES.md (the park, the interior
/// and the studio also ship in assets/maps/).
struct RealMap {
    file: &'static str,
    size: (usize, usize),
    max: [f64; 3],
    mean: [f64; 3],
}

const REAL_MAPS: &[RealMap] = &[
    RealMap { file: "grace_probe.hdr", size: (1000, 1000), max: [652.0, 524.0, 246.0], mean: [0.5315, 0.2868, 0.3547] },
    // Channels are stored B, G, R in this file: R's maximum is the largest.
    RealMap {
        file: "grace_latlong.exr",
        size: (1024, 512),
        max: [18.375, 15.07, 6.895],
        mean: [0.01961, 0.01177, 0.01571],
    },
    RealMap {
        file: "grace-new_256x128.hdr",
        size: (256, 128),
        max: [3504.0, 2080.0, 1488.0],
        mean: [0.5883, 0.3867, 0.2759],
    },
    // The sun (69120) is above the half-float range: f32 end to end keeps it.
    RealMap {
        file: "rooitou_park_1k.hdr",
        size: (1024, 512),
        max: [69120.0, 66048.0, 40960.0],
        mean: [0.5116, 0.5341, 0.4567],
    },
    RealMap {
        file: "st_fagans_interior_1k.hdr",
        size: (1024, 512),
        max: [1272.0, 1088.0, 864.0],
        mean: [0.9117, 0.7052, 0.4389],
    },
    RealMap {
        file: "studio_small_03_1k.hdr",
        size: (1024, 512),
        max: [3088.0, 3408.0, 3568.0],
        mean: [1.636, 1.882, 2.127],
    },
];

#[test]
fn loadhdr_reads_the_real_environment_maps() {
    // The maps found, each from assets/maps/ when it ships there, else from ../shared/data.
    let found: Vec<(usize, &RealMap)> = REAL_MAPS
        .iter()
        .enumerate()
        .filter(|(_, m)| {
            let there = common::real_map(m.file).is_file();
            if !there {
                common::skip_missing_data(&format!("{} not found; LoadHdr was not checked on it", m.file));
            }
            there
        })
        .collect();
    let sb = Sandbox::new();
    let mut nodes = String::new();
    for &(i, m) in &found {
        nodes.push_str(&format!("        \"map{i}\": LoadHdr(path: {}),\n", ron_path(&common::real_map(m.file))));
        nodes.push_str(&format!("        \"save{i}\": Save(input: \"map{i}\", path: \"map{i}.pfm\"),\n"));
    }
    let graph = sb.write("real.ron", format!("(\n    nodes: {{\n{nodes}    }},\n)\n"));
    let (o, r) = sb.run(&graph, &["--no-cache"]);
    o.assert_success();
    assert_eq!(r.expect("report").with_status("computed").len(), 2 * found.len());

    let mut problems = Vec::new();
    for &(i, m) in &found {
        let img = decode_pfm(&sb.out().join(format!("map{i}.pfm")));
        if (img.width, img.height) != m.size {
            problems.push(format!("{}: {}x{}, expected {}x{}", m.file, img.width, img.height, m.size.0, m.size.1));
            continue;
        }
        if let Some(bad) = img.data.iter().find(|v| !v.is_finite() || **v < 0.0) {
            problems.push(format!("{}: value {bad} (the file has no NaN, Inf or negative values)", m.file));
        }
        let n = (img.width * img.height) as f64;
        for (c, (&want_max, &want_mean)) in m.max.iter().zip(&m.mean).enumerate() {
            let max = img.data.iter().skip(c).step_by(3).fold(0f32, |a, &v| a.max(v)) as f64;
            let mean = img.data.iter().skip(c).step_by(3).map(|&v| v as f64).sum::<f64>() / n;
            if (max - want_max).abs() > 0.005 * want_max {
                problems.push(format!("{}: channel {c} max {max}, expected {want_max}", m.file));
            }
            if (mean - want_mean).abs() > 0.01 * want_mean {
                problems.push(format!("{}: channel {c} mean {mean}, expected {want_mean}", m.file));
            }
        }
    }
    assert!(problems.is_empty(), "real maps:\n  {}\n{}", problems.join("\n  "), o.describe());
}

// ---------------------------------------------------------------------------------------------
// Exit codes
// ---------------------------------------------------------------------------------------------

#[test]
fn exit_codes_distinguish_usage_errors_from_run_errors() {
    let sb = Sandbox::new();
    let graph = sb.write("branches.ron", BRANCHES);

    let (o, _) = sb.run(&graph, &["--target", "nosuch"]);
    o.assert_code(2).assert_stderr_contains("unknown target node \"nosuch\"");
    let mut plan = hdrflow_command([OsStr::new("plan"), graph.as_os_str()]);
    plan.arg("--cache-dir").arg(sb.cache()).args(["--target", "nosuch"]);
    run_command(plan, RUN_TIMEOUT).assert_code(2).assert_stderr_contains("nosuch");

    let (o, _) = sb.run(&graph, &["--set", "exp.stops"]);
    o.assert_code(2).assert_stderr_contains("expected NODE.FIELD=VALUE");
    let (o, _) = sb.run(&graph, &["--set", "stops=2.0"]);
    o.assert_code(2).assert_stderr_contains("expected NODE.FIELD=VALUE");
    let (o, _) = sb.run(&graph, &["--set", "exp.stops="]);
    o.assert_code(2).assert_stderr_contains("--set exp.stops");
    let (o, _) = sb.run(&graph, &["--set", "nosuch.stops=2.0"]);
    o.assert_code(2).assert_stderr_contains("no node named \"nosuch\"");
    let (o, _) = sb.run(&graph, &["--set", "exp.stops=\"two\""]);
    o.assert_code(2).assert_stderr_contains("--set exp.stops").assert_stderr_contains("field \"stops\"");
    let (o, _) = sb.run(&graph, &["--set", "exp.bogus=1"]);
    o.assert_code(2).assert_stderr_contains("Exposure has no field \"bogus\"");
    let (o, _) = sb.run(&sb.join("no_such_pipeline.ron"), &[]);
    o.assert_code(2).assert_stderr_contains("no_such_pipeline.ron");
    run_hdrflow(["run"]).assert_code(2);
    run_hdrflow(["frobnicate"]).assert_code(2);
    assert!(files_under(&sb.out()).is_empty(), "a refused run wrote outputs");
    assert!(files_under(&sb.cache()).is_empty(), "a refused run wrote to the cache");

    // A missing input file is a pipeline error, at the field that names it.
    let missing = sb.write("missing.ron", load_and_save("missing.pfm"));
    let (o, _) = sb.run(&missing, &[]);
    o.assert_code(2).assert_stderr_contains(r#"missing.ron:3:31: node "env": field "path": input file "missing.pfm""#);
    let mut plan = hdrflow_command([OsStr::new("plan"), missing.as_os_str()]);
    plan.arg("--cache-dir").arg(sb.cache());
    run_command(plan, RUN_TIMEOUT).assert_code(2).assert_stderr_contains("missing.pfm");
    assert!(files_under(&sb.out()).is_empty() && files_under(&sb.cache()).is_empty());

    // A run error: the input file is there, but is not what its extension says.
    let corrupt = sb.write("corrupt.ron", load_and_save("corrupt.pfm"));
    sb.write("corrupt.pfm", b"not a PFM file");
    let (o, _) = sb.run(&corrupt, &[]);
    o.assert_code(1).assert_stderr_contains("corrupt.pfm");
}
