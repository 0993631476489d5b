//! Issue 38, the loading end: `LoadImage` and `LoadBrackets` on tiny PNG, JPEG and TIFF files
//! that the test writes itself (with their EXIF blocks, through `hdrflow::formats::photo` and
//! `kamadak-exif`), a bracket saved with `Save(path: "frames/")` and loaded back with its exposure
//! times, and every bad bracket of the issue refused with a message naming the file: at
//! validation (exit code 2) when the headers tell, else at the run (exit code 1), never a panic.

mod common;

use std::io::Cursor;
use std::path::Path;

use common::{ron_path, Sandbox};
use exif::{Field, In, Rational, Tag, Value as ExifValue};
use hdrflow::formats::photo::encode::encode_frame;
use hdrflow::values::brackets::Codes;
use hdrflow::values::{Brackets, Exif, Image};
use image::ImageEncoder;

/// A `w x h` 8-bit frame whose codes encode (x, y, channel) and a level.
fn codes8(w: usize, h: usize, level: u8) -> Codes {
    Codes::U8((0..w * h * 3).map(|i| ((i * 7) as u8).wrapping_add(level)).collect())
}

fn codes16(w: usize, h: usize) -> Codes {
    Codes::U16((0..w * h * 3).map(|i| (i * 997 % 65536) as u16).collect())
}

fn write_frame(dir: &Path, name: &str, w: usize, codes: &Codes, time: f64) {
    let ext = Path::new(name).extension().unwrap().to_str().unwrap();
    let bytes = encode_frame(w, codes.len() / 3 / w, codes, time, ext).unwrap();
    common::write_file(&dir.join(name), bytes);
}

/// A PNG with every EXIF field `LoadImage` reports, and orientation 6 (the camera turned a
/// quarter clockwise: the stored rows are the scene's columns).
fn oriented_png(w: u32, h: u32, rgb: &[u8]) -> Vec<u8> {
    let f = |tag, value| Field { tag, ifd_num: In::PRIMARY, value };
    let fields = [
        f(Tag::Orientation, ExifValue::Short(vec![6])),
        f(Tag::ExposureTime, ExifValue::Rational(vec![Rational { num: 1, denom: 125 }])),
        f(Tag::FNumber, ExifValue::Rational(vec![Rational { num: 56, denom: 10 }])),
        f(Tag::PhotographicSensitivity, ExifValue::Short(vec![200])),
        f(Tag::Make, ExifValue::Ascii(vec![b"Canon".to_vec()])),
        f(Tag::Model, ExifValue::Ascii(vec![b"EOS R5".to_vec()])),
    ];
    let mut writer = exif::experimental::Writer::new();
    for field in &fields {
        writer.push_field(field);
    }
    let mut block = Cursor::new(Vec::new());
    writer.write(&mut block, false).unwrap();
    let mut out = Vec::new();
    let mut e = image::codecs::png::PngEncoder::new(&mut out);
    e.set_exif_metadata(block.into_inner()).unwrap();
    e.write_image(rgb, w, h, image::ExtendedColorType::Rgb8).unwrap();
    out
}

#[test]
fn load_image_applies_the_orientation_and_reads_the_exif() {
    let sb = Sandbox::new();
    // Stored 3 wide, 2 high; pixel (x, y) has R = 10 x + 100 y.
    let rgb: Vec<u8> = (0..2).flat_map(|y| (0..3).flat_map(move |x| [10 * x + 100 * y, 0, 255])).collect();
    let png = sb.write("turned.png", oriented_png(3, 2, &rgb));
    let grey = sb.join("grey16.png");
    image::save_buffer(&grey, &[0, 0, 255, 255], 2, 1, image::ExtendedColorType::L16).unwrap();
    let text = format!(
        r#"(nodes: {{
            "codes": LoadImage(path: {}, encoding: Codes),
            "srgb": LoadImage(path: {}),
            "grey": LoadImage(path: {}),
        }})"#,
        ron_path(&png),
        ron_path(&png),
        ron_path(&grey)
    );
    let v = common::run_text(&text, &["codes", "codes.exif", "srgb", "grey"]).unwrap();
    let img = v["codes"].get::<Image>().unwrap();
    // Orientation 6: the output is 2 wide, 3 high; output (x, y) is stored (y, H - 1 - x).
    assert_eq!((img.width, img.height, img.channels), (2, 3, 3));
    for y in 0..3 {
        for x in 0..2 {
            let stored = 10 * y + 100 * (1 - x);
            assert_eq!(img.pixel(x, y), [stored as f32, 0.0, 255.0], "({x}, {y})");
        }
    }
    let exif = v["codes.exif"].get::<Exif>().unwrap();
    assert_eq!(exif.exposure_time, Some(1.0 / 125.0));
    assert_eq!((exif.f_number, exif.iso), (Some(5.6), Some(200.0)));
    assert_eq!((exif.make.as_deref(), exif.model.as_deref()), (Some("Canon"), Some("EOS R5")));
    // Auto on an 8-bit file: sRGB decoded (255 -> 1, 0 -> 0).
    let srgb = v["srgb"].get::<Image>().unwrap();
    assert_eq!(srgb.pixel(0, 0)[1..], [0.0, 1.0]);
    // Auto on a 16-bit grey file: linear, grey expanded to RGB; no EXIF, no settings.
    let g = v["grey"].get::<Image>().unwrap();
    assert_eq!((g.width, g.channels), (2, 3));
    assert_eq!((g.pixel(0, 0), g.pixel(1, 0)), ([0.0; 3].as_slice(), [1.0; 3].as_slice()));
}

#[test]
fn a_saved_bracket_loads_back_with_its_times_in_every_format() {
    let sb = Sandbox::new();
    let (w, h) = (6, 4);
    let times = [1.0 / 1000.0, 1.0 / 250.0, 1.0 / 62.5];
    // Files named against exposure order: the bracket is sorted by time, not by name.
    let kitchen = sb.join("captures/kitchen");
    for (name, t, level) in [("a.jpg", times[2], 2), ("b.jpg", times[0], 0), ("c.jpg", times[1], 1)] {
        write_frame(&kitchen, name, w, &codes8(w, h, 40 * level), t);
    }
    let tiffs = sb.join("captures/tiffs");
    for (k, t) in times.iter().enumerate() {
        write_frame(&tiffs, &format!("t{k}.tif"), w, &codes16(w, h), *t);
    }
    let graph = sb.write(
        "load.ron",
        r#"(nodes: {
            "jpg": LoadBrackets(paths: "captures/kitchen"),
            "tif": LoadBrackets(paths: "captures/tiffs/*.tif"),
            "save_jpg": Save(input: "jpg", path: "frames/"),
            "save_tif": Save(input: "tif", path: "tiff_frames/f_{frame}.tif"),
        })"#,
    );
    let (o, _) = sb.run_ok(&graph, &[]);
    assert!(!o.stderr.contains("panicked"), "{}", o.describe());
    let out = sb.out();
    let written = common::files_under(&out);
    for f in ["frames/frame_0.png", "frames/frame_1.png", "frames/frame_2.png", "tiff_frames/f_2.tif"] {
        assert!(written.iter().any(|p| p == Path::new(f)), "{f} not in {written:?}");
    }
    // The saved frames load back: same codes, same times, shortest first.
    let text = format!(
        r#"(nodes: {{ "png": LoadBrackets(paths: {}), "tif": LoadBrackets(paths: {}) }})"#,
        ron_path(&out.join("frames/")),
        ron_path(&out.join("tiff_frames"))
    );
    let v = common::run_text(&text, &["png", "tif"]).unwrap();
    let png = v["png"].get::<Brackets>().unwrap();
    assert_eq!((png.width, png.height, png.bit_depth, png.frames.len()), (w, h, 8, 3));
    let got: Vec<f64> = png.frames.iter().map(|f| f.time).collect();
    assert_eq!(got, times);
    // PNG is lossless: each saved frame holds exactly the codes the JPEG decoded to.
    let original =
        common::run_text(&format!(r#"(nodes: {{ "b": LoadBrackets(paths: {}) }})"#, ron_path(&kitchen)), &["b"])
            .unwrap();
    let original = original["b"].get::<Brackets>().unwrap();
    let names: Vec<&str> = original.frames.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["b.jpg", "c.jpg", "a.jpg"]);
    for (a, b) in png.frames.iter().zip(&original.frames) {
        assert_eq!(a.codes, b.codes, "{}", b.name);
    }
    let tif = v["tif"].get::<Brackets>().unwrap();
    assert_eq!((tif.bit_depth, tif.frames[2].time), (16, times[2]));
    assert_eq!(tif.frames[0].codes, codes16(w, h));
}

#[test]
fn given_exposure_times_replace_missing_exif_in_name_order() {
    let sb = Sandbox::new();
    let dir = sb.join("plain");
    std::fs::create_dir_all(&dir).unwrap();
    for (k, name) in ["x1.png", "x2.png"].iter().enumerate() {
        let Codes::U8(rgb) = codes8(4, 2, k as u8) else { unreachable!() };
        image::save_buffer(dir.join(name), &rgb, 4, 2, image::ExtendedColorType::Rgb8).unwrap();
    }
    let text = format!(r#"(nodes: {{ "b": LoadBrackets(paths: {}, exposure_times: [0.5, 0.125]) }})"#, ron_path(&dir));
    let v = common::run_text(&text, &["b"]).unwrap();
    let b = v["b"].get::<Brackets>().unwrap();
    let got: Vec<(&str, f64)> = b.frames.iter().map(|f| (f.name.as_str(), f.time)).collect();
    assert_eq!(got, [("x2.png", 0.125), ("x1.png", 0.5)]);
}

/// Runs `LoadBrackets(paths: PATHS[, exposure_times: TIMES])` into a Save; returns the output
/// and the positions (`FILE:1:COLUMN`) of the two fields' values, where validation reports them.
fn run_bad(sb: &Sandbox, name: &str, paths: &str, times: Option<&str>) -> (common::Output, [String; 2]) {
    let times_field = times.map(|t| format!(", exposure_times: {t}")).unwrap_or_default();
    let text = format!(
        r#"(nodes: {{ "b": LoadBrackets(paths: {paths:?}{times_field}), "s": Save(input: "b", path: "f/") }})"#
    );
    let column = |needle: &str| text.find(needle).map_or(0, |i| i + needle.len() + 1);
    let at = [column("paths: "), column("exposure_times: ")].map(|c| format!("{name}.ron:1:{c}:"));
    let graph = sb.write(format!("{name}.ron"), &text);
    let (o, _) = sb.run_in(&graph, &sb.join(format!("out_{name}")), &sb.cache(), &[]);
    assert!(!o.stderr.contains("panicked"), "{name}\n{}", o.describe());
    (o, at)
}

#[test]
fn every_bad_bracket_is_a_clear_error_naming_the_file() {
    let sb = Sandbox::new();
    let (w, h) = (4, 2);
    let d = |name: &str| sb.join(name);
    write_frame(&d("sizes"), "a.png", w, &codes8(w, h, 0), 0.01);
    write_frame(&d("sizes"), "b.png", w + 1, &codes8(w + 1, h, 0), 0.02);
    write_frame(&d("one"), "a.png", w, &codes8(w, h, 0), 0.01);
    write_frame(&d("same"), "a.png", w, &codes8(w, h, 0), 0.01);
    write_frame(&d("same"), "b.jpg", w, &codes8(w, h, 0), 0.01);
    write_frame(&d("depth"), "a.png", w, &codes8(w, h, 0), 0.01);
    write_frame(&d("depth"), "b.png", w, &codes16(w, h), 0.02);
    write_frame(&d("count"), "a.png", w, &codes8(w, h, 0), 0.01);
    write_frame(&d("count"), "b.png", w, &codes8(w, h, 0), 0.02);
    write_frame(&d("notimage"), "a.png", w, &codes8(w, h, 0), 0.01);
    common::write_file(&d("notimage/b.jpg"), b"this is not a JPEG");
    std::fs::create_dir_all(d("empty")).unwrap();
    common::write_file(&d("noexif/a.png"), {
        let mut v = Vec::new();
        image::codecs::png::PngEncoder::new(&mut v)
            .write_image(&[0; 24], 4, 2, image::ExtendedColorType::Rgb8)
            .unwrap();
        v
    });
    write_frame(&d("noexif"), "b.png", w, &codes8(w, h, 0), 0.02);

    let cases: [(&str, &str, Option<&str>, &str); 9] = [
        ("sizes", "sizes", None, "frame b.png is 5x2, but a.png is 4x2"),
        ("one", "one/", None, "a bracket needs at least two frames; found only a.png"),
        ("same", "same", None, "frames a.png and b.jpg have the same exposure time 1/100 s"),
        ("depth", "depth", None, "frame b.png has 16 bits per channel, but a.png has 8"),
        ("count", "count", Some("[0.5]"), "1 exposure times for 2 files"),
        ("notimage", "notimage", None, "file b.jpg is not an image"),
        ("empty", "empty/", None, "folder \"empty/\" holds no photograph"),
        ("glob", "sizes/*.tif", None, "no file matches \"sizes/*.tif\""),
        ("noexif", "noexif", None, "frame a.png has no EXIF exposure time: give exposure_times"),
    ];
    for (name, paths, times, message) in cases {
        let (o, [at_paths, at_times]) = run_bad(&sb, name, paths, times);
        o.assert_code(2).assert_stderr_contains(message);
        // Reported at the field the problem is about.
        o.assert_stderr_contains(if times.is_some() { &at_times } else { &at_paths });
    }
    // Given times fix the missing EXIF; a non-positive one is refused by the field's range.
    run_bad(&sb, "noexif_given", "noexif", Some("[0.01, 0.02]")).0.assert_success();
    run_bad(&sb, "zero", "count", Some("[0.0, 0.02]"))
        .0
        .assert_code(2)
        .assert_stderr_contains("exposure time 0 for a.png is not a positive number of seconds");
    // A 16-bit bracket cannot be saved as JPEG: a run error naming the path.
    write_frame(&d("deep"), "a.png", w, &codes16(w, h), 0.01);
    write_frame(&d("deep"), "b.png", w, &codes16(w, h), 0.02);
    let graph = sb.write(
        "deep.ron",
        r#"(nodes: { "b": LoadBrackets(paths: "deep"), "s": Save(input: "b", path: "f/x_{frame}.jpg") })"#,
    );
    let (o, _) = sb.run_in(&graph, &sb.join("out_deep"), &sb.cache(), &[]);
    o.assert_code(1).assert_stderr_contains("JPEG holds 8 bits per channel");
    // A bracket saved to one file is refused before the run.
    let graph =
        sb.write("onefile.ron", r#"(nodes: { "b": LoadBrackets(paths: "count", exposure_times: [1.0, 2.0]), "s": Save(input: "b", path: "b.png") })"#);
    let (o, _) = sb.run_in(&graph, &sb.join("out_onefile"), &sb.cache(), &[]);
    o.assert_code(2).assert_stderr_contains("brackets are saved one file per frame");
}

#[test]
fn a_batch_over_capture_folders_runs_one_item_per_folder() {
    let sb = Sandbox::new();
    let (w, h) = (4, 2);
    for (folder, n) in [("kitchen", 3), ("attic", 2)] {
        for k in 0..n {
            write_frame(
                &sb.join(format!("captures/{folder}")),
                &format!("f{k}.jpg"),
                w,
                &codes8(w, h, k),
                0.01 * (1 << k) as f64,
            );
        }
    }
    common::write_file(&sb.join("captures/readme.txt"), b"not a capture folder");
    let graph = sb.write(
        "batch.ron",
        r#"(nodes: { "brackets": LoadBrackets(paths: "captures/kitchen/"), "s": Save(input: "brackets", path: "frames/") })"#,
    );
    let over = format!("brackets.paths={}/captures/*/", sb.path().display());
    let o = common::run_hdrflow([
        "batch",
        &graph.display().to_string(),
        "--over",
        &over,
        "--out",
        &sb.out().display().to_string(),
        "--cache-dir",
        &sb.cache().display().to_string(),
    ]);
    o.assert_success();
    let written = common::files_under(&sb.out());
    let frames: Vec<String> =
        written.iter().map(|p| p.display().to_string()).filter(|p| p.contains("/frames/")).collect();
    assert_eq!(
        frames,
        [
            "attic/frames/frame_0.png",
            "attic/frames/frame_1.png",
            "kitchen/frames/frame_0.png",
            "kitchen/frames/frame_1.png",
            "kitchen/frames/frame_2.png"
        ],
        "{}",
        o.describe()
    );
}

#[test]
fn the_cache_key_follows_the_files_contents_and_names_not_their_times_on_disk() {
    let sb = Sandbox::new();
    let (w, h) = (4, 2);
    for (k, t) in [0.01, 0.04].iter().enumerate() {
        write_frame(&sb.join("a"), &format!("f{k}.png"), w, &codes8(w, h, k as u8), *t);
    }
    let graph =
        sb.write("cache.ron", r#"(nodes: { "b": LoadBrackets(paths: "a"), "s": Save(input: "b", path: "f/") })"#);
    let (_, first) = sb.run_ok(&graph, &[]);
    assert_eq!(first.status_of("b"), "computed");
    // The same bytes written again (a new modification time): the same key.
    write_frame(&sb.join("a"), "f1.png", w, &codes8(w, h, 1), 0.04);
    let (_, again) = sb.run_ok(&graph, &[]);
    // (The saved frames are found in the cache, so the bracket is not even needed.)
    assert_eq!((again.status_of("s"), again.status_of("b")), ("cached", "not needed"), "{:#?}", again.status);
    // One frame's time changed in its EXIF: a new key.
    write_frame(&sb.join("a"), "f1.png", w, &codes8(w, h, 1), 0.08);
    let (_, edited) = sb.run_ok(&graph, &[]);
    assert_eq!(edited.status_of("b"), "computed");
    // A renamed frame: a new key (the names are in it).
    std::fs::rename(sb.join("a/f1.png"), sb.join("a/g1.png")).unwrap();
    let (_, renamed) = sb.run_ok(&graph, &[]);
    assert_eq!(renamed.status_of("b"), "computed");
    assert_ne!(renamed.key_of("b"), edited.key_of("b"));
    // The folder moved (another machine's layout): the key holds no path, so the same key.
    std::fs::rename(sb.join("a"), sb.join("moved")).unwrap();
    let graph =
        sb.write("moved.ron", r#"(nodes: { "b": LoadBrackets(paths: "moved/"), "s": Save(input: "b", path: "f/") })"#);
    let (_, moved) = sb.run_ok(&graph, &[]);
    assert_eq!(moved.key_of("b"), renamed.key_of("b"));
}

#[test]
fn load_image_saves_its_exif_as_json_and_refuses_missing_or_broken_files() {
    let sb = Sandbox::new();
    write_frame(&sb.path().join("shots"), "one.jpg", 4, &codes8(4, 2, 0), 1.0 / 30.0);
    let graph = sb.write(
        "exif.ron",
        r#"(nodes: { "img": LoadImage(path: "shots/one.jpg"), "s": Save(input: "img.exif", path: "exif.json") })"#,
    );
    sb.run_ok(&graph, &[]);
    let json: serde_json::Value = serde_json::from_slice(&common::read_file(&sb.out().join("exif.json"))).unwrap();
    assert_eq!(json["exposure_time"], 1.0 / 30.0);
    assert!(json["make"].is_null() && json["iso"].is_null(), "{json}");
    // A missing file: found by validation (exit code 2) at its field.
    let missing = sb.write(
        "missing.ron",
        r#"(nodes: { "img": LoadImage(path: "shots/none.jpg"), "s": Save(input: "img", path: "x.exr") })"#,
    );
    let (o, _) = sb.run_in(&missing, &sb.join("out_missing"), &sb.cache(), &[]);
    o.assert_code(2).assert_stderr_contains("input file \"shots/none.jpg\" does not exist");
    // Not an image: a run error naming the file, never a panic.
    common::write_file(&sb.path().join("shots/text.png"), b"plain text, not a PNG");
    let broken = sb.write(
        "broken.ron",
        r#"(nodes: { "img": LoadImage(path: "shots/text.png"), "s": Save(input: "img", path: "x.exr") })"#,
    );
    let (o, _) = sb.run_in(&broken, &sb.join("out_broken"), &sb.cache(), &[]);
    o.assert_code(1).assert_stderr_contains("text.png").assert_stderr_contains("is not an image");
    assert!(!o.stderr.contains("panicked"), "{}", o.describe());
}
