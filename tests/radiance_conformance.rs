//! Radiance (`.hdr`, RGBE) conformance against files we did not write: eight files from Radiance
//! itself and from the `image` crate's test images (`tests/data/radiance/`, see its README),
//! compared with values two independent readers computed once (`scripts/rgbe-oracle.py` ->
//! `tests/data/radiance/expected.json`), so CI needs neither:
//!
//! - **Radiance's own reader** (`getheader`, `fgetsresolu`, `freadcolrs`, and `pix2loc` for where
//!   each pixel goes, from LBNL-ETA/Radiance), for every file and for all eight resolution-line
//!   layouts: the raw RGBE bytes, converted by the oracle script with m * 2^(E-136).
//! - **OpenImageIO** 3.2 for the files it reads, and for the eight layouts (`Orientation` 1-8,
//!   then `ImageBufAlgo::reorient`: the image as displayed). It cannot read old-style RLE
//!   (`old-rle.hdr`, `cabin.hdr`: "Read error reading pixels on scanline N"), it refuses headers
//!   without a `FORMAT=` line, which Radiance reads as RGBE (`cabin.hdr`, `rgbw.pic`: it read a
//!   copy with the line inserted, pixel bytes unchanged), and it rotates `+X +Y` and `-X -Y` by
//!   180 degrees compared with Radiance (Orientation 6 and 8 swapped): see the layouts test.
//!
//! What "the same image" means here: the image as displayed (row 0 at the top, after the
//! resolution line's flips and transposition), with the values as stored in the file, i.e.
//! before our reader divides by the product of the `EXPOSURE` lines: we decode with
//! `ColorSpace::AsStored` (no `PRIMARIES` conversion) and multiply by that product (computed by
//! the oracle script from the header) before comparing. Neither oracle applies `EXPOSURE`
//! (Radiance's tools keep exposed values; OpenImageIO reports only the *last* line as
//! `hdr:exposure`, `Earth.hdr` has two).
//!
//! The 0.5: Radiance's own `colr_color` decodes a mantissa m as (m + 0.5) * 2^(E-136); we,
//! OpenImageIO, stb_image and the `image` crate use m * 2^(E-136) (see `formats::rgbe`). The
//! oracle script therefore converts Radiance's *bytes* with m * 2^(E-136), which makes the
//! comparison exact; with `colr_color`'s convention every value would be higher by half a
//! mantissa step (at most 1/256 of the pixel's largest channel): the recorded `colr_color_means`
//! are 0.2% to 3.3% above ours on these files (0.4% on `macbeth_pub.pic`, 3.2% where a channel
//! is mostly tiny mantissas next to a large one, `rgbr4x4.hdr`'s G and B), which is that
//! convention, not an error.
//!
//! Tolerances, and why:
//! - Size: exact. Files without `EXPOSURE`: every sample, min and max exactly equal to Radiance's
//!   bytes converted (m * 2^(E-136) is exact in f32, down to E = 1 in `scale.hdr`); means within
//!   [`MEAN_SUM_TOL`] (float64 sums in another order).
//! - With `EXPOSURE` (product P): our f32 value is m * f32(2^(E-136) / P), two roundings, then
//!   multiplied by P in f64 here: relative error <= 2^-23 ([`REL_TOL`] = 2^-22 leaves room for the
//!   f64 products). Measured: at most 8.0e-8 (`Earth.hdr`, `mesh_cyl.hdr`).
//! - Against OpenImageIO: [`REL_TOL`] as well; its exponent table is rounded decimal constants,
//!   off by one f32 ulp at some exponents (in `scale.hdr`, none of them sampled). Measured: the
//!   same 8.0e-8 (from EXPOSURE), elsewhere only the float64 means differ (at most 2.4e-16).

use hdrflow::formats::{decode_by_extension_with, rgbe, ColorSpace, DecodeOptions};
use hdrflow::values::Image;
use serde_json::Value;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/radiance");
/// Relative tolerance where an `EXPOSURE` division or OpenImageIO's rounding is involved.
const REL_TOL: f64 = 2.4e-7;
/// Means are float64 sums in different orders (numpy's pairwise, ours sequential).
const MEAN_SUM_TOL: f64 = 1e-12;

fn expected() -> Value {
    serde_json::from_str(&std::fs::read_to_string(format!("{DIR}/expected.json")).unwrap()).unwrap()
}

fn bytes(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}/{name}")).unwrap()
}

fn decode_raw(name: &str, bytes: &[u8]) -> Image {
    let ext = name.rsplit('.').next().unwrap();
    let options = DecodeOptions { colorspace: ColorSpace::AsStored, ..Default::default() };
    decode_by_extension_with(bytes, ext, &options).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn at(img: &Image, x: usize, y: usize, k: usize) -> f64 {
    img.data[(y * img.width + x) * img.channels + k] as f64
}

fn channel_stats(img: &Image, k: usize) -> (f64, f64, f64) {
    let v: Vec<f64> =
        img.data.iter().skip(k).step_by(img.channels).map(|&v| v as f64).filter(|v| v.is_finite()).collect();
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (mean, v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(f64::NEG_INFINITY, f64::max))
}

fn rel(got: f64, want: f64) -> f64 {
    if got == want {
        0.0
    } else {
        (got - want).abs() / want.abs().max(f64::MIN_POSITIVE)
    }
}

/// Compares `img` (times `scale`, the EXPOSURE product) with one oracle's entry (`width`,
/// `height`, per channel `mean`, `min`, `max`, `samples`); returns the worst relative error.
fn compare(what: &str, img: &Image, e: &Value, scale: f64, tol: f64) -> f64 {
    assert_eq!(
        (img.width as u64, img.height as u64),
        (e["width"].as_u64().unwrap(), e["height"].as_u64().unwrap()),
        "{what}: size"
    );
    let mut worst = 0f64;
    let mut check = |got: f64, want: f64, tol: f64, label: &str| {
        let r = rel(got, want);
        // Exact means exact in f32: serde_json may parse a decimal 1 ulp of f64 away.
        let ok = if tol == 0.0 { got as f32 == want as f32 } else { r <= tol };
        assert!(ok, "{what}: {label}: {got:e} vs {want:e} (relative {r:e})");
        worst = worst.max(r);
    };
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let ch = &e["channels"][c];
        let (mean, min, max) = channel_stats(img, k);
        // (The oracle's float64 mean sums in another order: MEAN_SUM_TOL.)
        check(mean * scale, ch["mean"].as_f64().unwrap(), tol.max(MEAN_SUM_TOL), &format!("{c} mean"));
        check(min * scale, ch["min"].as_f64().unwrap(), tol, &format!("{c} min"));
        check(max * scale, ch["max"].as_f64().unwrap(), tol, &format!("{c} max"));
        for s in ch["samples"].as_array().unwrap() {
            let (x, y) = (s[0].as_u64().unwrap() as usize, s[1].as_u64().unwrap() as usize);
            check(at(img, x, y, k) * scale, s[2].as_f64().unwrap(), tol, &format!("{c} at ({x}, {y})"));
        }
    }
    worst
}

fn exposure_product(e: &Value) -> f64 {
    e["header"]["exposure_product"].as_f64().unwrap()
}

/// Our tolerance for a file: exact without EXPOSURE, [`REL_TOL`] with it.
fn tolerance(e: &Value) -> f64 {
    if exposure_product(e) == 1.0 {
        0.0
    } else {
        REL_TOL
    }
}

#[test]
fn every_file_matches_radiance_own_reader() {
    let exp = expected();
    let files = exp["files"].as_object().unwrap();
    assert_eq!(files.len(), 8);
    for (name, e) in files {
        let b = bytes(name);
        let img = decode_raw(name, &b);
        assert_eq!(rgbe::header_size(&b).unwrap(), (img.width, img.height), "{name}: header_size");
        let worst = compare(&format!("{name} (Radiance)"), &img, &e["radiance"], exposure_product(e), tolerance(e));
        eprintln!("{name}: {}x{}, worst relative error against Radiance {worst:.1e}", img.width, img.height);
    }
}

#[test]
fn files_openimageio_reads_match_it() {
    let exp = expected();
    let mut compared = 0;
    for (name, e) in exp["files"].as_object().unwrap() {
        let oiio = &e["oiio"];
        if let Some(error) = oiio["error"].as_str() {
            // Old-style RLE: OpenImageIO 3.2 fails; Radiance's reader is the oracle above.
            eprintln!("{name}: not compared with OpenImageIO (it failed: {error})");
            assert!(["old-rle.hdr", "cabin.hdr"].contains(&name.as_str()), "{name}: {error}");
            continue;
        }
        let img = decode_raw(name, &bytes(name));
        let worst = compare(&format!("{name} (OpenImageIO)"), &img, oiio, exposure_product(e), REL_TOL);
        eprintln!("{name}: worst relative error against OpenImageIO {worst:.1e} ({})", oiio["input"]);
        compared += 1;
    }
    assert_eq!(compared, 6);
}

/// The bytes of `name` with its resolution line replaced by `line`.
fn with_resolution_line(b: &[u8], line: &str) -> Vec<u8> {
    let start = b.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let end = start + b[start..].iter().position(|&c| c == b'\n').unwrap();
    [&b[..start], line.as_bytes(), &b[end..]].concat()
}

/// `img` rotated by 180 degrees.
fn rotated_180(img: &Image) -> Image {
    let data = img.data.chunks_exact(img.channels).rev().flatten().copied().collect();
    Image::from_vec(img.width, img.height, img.channels, data)
}

#[test]
fn all_eight_layouts_match_radiance_and_openimageio() {
    // `-Y n +X m` (standard), `+Y` (bottom to top), `-X` (right to left) and the transposed
    // `±X n ±Y m` (scanlines are columns), written over the resolution line of a new-style RLE
    // file (`mesh_cyl.hdr`, with EXPOSURE) and a flat one (`scale.hdr`). Radiance's `pix2loc`
    // defines where each pixel goes; OpenImageIO agrees except for `+X +Y` and `-X -Y`, which it
    // maps to EXIF Orientation 6 and 8 where Radiance's definition is 8 and 6: its image is
    // rotated by 180 degrees there (recorded by the oracle script as "rotated 180").
    let exp = expected();
    let (mut n, mut rotated) = (0, 0);
    for (name, e) in exp["files"].as_object().unwrap() {
        let Some(layouts) = e["layouts"].as_object() else { continue };
        let b = bytes(name);
        assert_eq!(layouts.len(), 8, "{name}");
        for (line, want) in layouts {
            let img = decode_raw(name, &with_resolution_line(&b, line));
            let what = format!("{name} as \"{line}\"");
            let worst =
                compare(&format!("{what} (Radiance)"), &img, &want["radiance"], exposure_product(e), tolerance(e));
            let orientation = &want["oiio_orientation"];
            let worst_oiio = match want["oiio_vs_radiance"].as_str().unwrap() {
                "same" => compare(&format!("{what} (OpenImageIO)"), &img, &want["oiio"], exposure_product(e), REL_TOL),
                "rotated 180" => {
                    assert!(
                        line.starts_with("+X") && line.contains("+Y") || line.starts_with("-X") && line.contains("-Y")
                    );
                    rotated += 1;
                    let what = format!("{what} rotated 180 (OpenImageIO, Orientation {orientation})");
                    compare(&what, &rotated_180(&img), &want["oiio"], exposure_product(e), REL_TOL)
                }
                other => panic!("{what}: OpenImageIO {other}"),
            };
            eprintln!(
                "{what}: {}x{}, worst relative error {worst:.1e} against Radiance, {worst_oiio:.1e} against \
                 OpenImageIO (Orientation {orientation}, {})",
                img.width, img.height, want["oiio_vs_radiance"]
            );
            n += 1;
        }
    }
    assert_eq!((n, rotated), (16, 4));
}

#[test]
fn primaries_lines_are_read() {
    let exp = expected();
    for (name, e) in exp["files"].as_object().unwrap() {
        let got = rgbe::primaries(&bytes(name));
        match e["header"]["primaries"].as_array() {
            None => assert!(got.is_none(), "{name}"),
            Some(v) => {
                let v: Vec<f64> = v.iter().map(|x| x.as_f64().unwrap()).collect();
                let p = got.unwrap_or_else(|| panic!("{name}: PRIMARIES not read"));
                let ours = [p.red, p.green, p.blue, p.white].concat();
                assert_eq!(ours, v, "{name}");
            }
        }
    }
}
