//! EXR conformance over a larger part of the OpenEXR project's test images: 44 files (32 MB) from
//! <https://github.com/AcademySoftwareFoundation/openexr-images> (pinned commit, sha256-checked by
//! `scripts/fetch-openexr-images.sh`, which re-creates the folder), shipped in
//! `tests/data/openexr-images` (or the folder `HDRFLOW_OPENEXR_IMAGES` names).
//!
//! Expected values: `tests/data/openexr/expected-fetched.json`, computed once with OpenEXR
//! 3.1.5's own C++ library (`scripts/openexr-cpp-oracle.cpp --channels`, which mirrors our part
//! and channel choice). For every file: the part chosen by default, the data window, and per
//! channel we return (`window: Data`, `colorspace: AsStored`) an FNV-1a 64 hash of every pixel's
//! f32 bits, so the whole image is compared **bit for bit**; the 25 sampled values and the mean
//! are checked too (and say where a difference is when the hash differs). Also, with
//! `window: Display`, the image is the display window with the data at its offset, 0 elsewhere.
//!
//! Without the files (all or some), the test skips through `common::skip`: a `SKIPPED` banner
//! (straight to stderr, so it shows even without `--nocapture`) and a pass, as CI does not
//! depend on the network; `HDRFLOW_REQUIRE_OPENEXR_IMAGES=1` makes missing files a failure.

mod common;

use std::io::Write;
use std::path::PathBuf;

use hdrflow::formats::exr::decode_with;
use hdrflow::formats::{ColorSpace, DecodeOptions, Window};
use hdrflow::values::Image;
use serde_json::Value;

/// Set by `.ci/run`: missing images fail the test instead of skipping it.
const REQUIRE: &str = "HDRFLOW_REQUIRE_OPENEXR_IMAGES";

const EXPECTED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/openexr/expected-fetched.json");

fn images_dir() -> PathBuf {
    match std::env::var_os("HDRFLOW_OPENEXR_IMAGES") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/openexr-images")),
    }
}

/// Printed past the test harness's output capture, so that the per-file log shows.
fn say(line: &str) {
    let _ = writeln!(std::io::stderr(), "{line}");
}

fn fnv1a64_f32_bits(values: impl Iterator<Item = f32>) -> String {
    let mut hash: u64 = 1469598103934665603;
    for v in values {
        for byte in v.to_bits().to_le_bytes() {
            hash ^= byte as u64;
            hash = hash.wrapping_mul(1099511628211);
        }
    }
    format!("{hash:016x}")
}

fn channel(img: &Image, k: usize) -> impl Iterator<Item = f32> + '_ {
    img.data.iter().skip(k).step_by(img.channels).copied()
}

fn same(ours: f32, expected: &Value) -> bool {
    match expected {
        Value::String(s) if s == "NaN" => ours.is_nan(),
        Value::String(s) if s == "inf" => ours == f32::INFINITY,
        Value::String(s) if s == "-inf" => ours == f32::NEG_INFINITY,
        v => v.as_f64().is_some_and(|v| ours == v as f32),
    }
}

/// Compares one file; `Err` describes every difference found.
fn check(bytes: &[u8], e: &Value) -> Result<String, String> {
    let raw = DecodeOptions { window: Window::Data, colorspace: ColorSpace::AsStored, ..Default::default() };
    let img = decode_with(bytes, &raw).map_err(|err| format!("decode failed: {err}"))?;
    let (w, h) = (e["size"][0].as_u64().unwrap() as usize, e["size"][1].as_u64().unwrap() as usize);
    let channels = e["channels"].as_array().unwrap();
    if (img.width, img.height, img.channels) != (w, h, channels.len()) {
        return Err(format!(
            "{}x{} x {} channels, OpenEXR {w}x{h} x {} channels",
            img.width,
            img.height,
            img.channels,
            channels.len()
        ));
    }
    let mut problems = Vec::new();
    for (k, c) in channels.iter().enumerate() {
        let cname = c["name"].as_str().unwrap();
        let hash = fnv1a64_f32_bits(channel(&img, k));
        if hash != c["fnv1a64_f32_bits"].as_str().unwrap() {
            problems.push(format!("{cname}: hash {hash}, OpenEXR {}", c["fnv1a64_f32_bits"]));
        }
        for s in c["samples"].as_array().unwrap() {
            let (x, y) = (s[0].as_u64().unwrap() as usize, s[1].as_u64().unwrap() as usize);
            let ours = img.data[(y * w + x) * img.channels + k];
            if !same(ours, &s[2]) {
                problems.push(format!("{cname} at ({x}, {y}): ours {ours:e}, OpenEXR {}", s[2]));
            }
        }
        let finite: Vec<f64> = channel(&img, k).filter(|v| v.is_finite()).map(f64::from).collect();
        let mean = if finite.is_empty() { 0.0 } else { finite.iter().sum::<f64>() / finite.len() as f64 };
        let want = c["mean"].as_f64().unwrap();
        if (mean - want).abs() > 1e-9 * want.abs().max(1.0) {
            problems.push(format!("{cname}: mean {mean}, OpenEXR {want}"));
        }
    }

    // The display window: the data at its offset, 0 elsewhere (our own placement, checked
    // against the Data decode above and the windows OpenEXR reported).
    let b = |key: &str| -> Vec<i64> { e[key].as_array().unwrap().iter().map(|v| v.as_i64().unwrap()).collect() };
    let (data, display) = (b("data_window"), b("display_window"));
    let shown = decode_with(bytes, &DecodeOptions { window: Window::Display, ..raw })
        .map_err(|err| format!("decode (display window) failed: {err}"))?;
    let (dw, dh) = ((display[2] - display[0] + 1) as usize, (display[3] - display[1] + 1) as usize);
    if (shown.width, shown.height) != (dw, dh) {
        problems.push(format!("display window {}x{}, OpenEXR {dw}x{dh}", shown.width, shown.height));
    } else {
        let c = img.channels;
        let mut bad = 0usize;
        for y in 0..dh {
            for x in 0..dw {
                let (fx, fy) = (x as i64 + display[0] - data[0], y as i64 + display[1] - data[1]);
                let inside = (0..w as i64).contains(&fx) && (0..h as i64).contains(&fy);
                let got = &shown.data[(y * dw + x) * c..(y * dw + x + 1) * c];
                let ok = if inside {
                    let want = &img.data[(fy as usize * w + fx as usize) * c..(fy as usize * w + fx as usize + 1) * c];
                    got.iter().zip(want).all(|(a, b)| a.to_bits() == b.to_bits())
                } else {
                    got.iter().all(|&v| v == 0.0)
                };
                bad += !ok as usize;
            }
        }
        if bad > 0 {
            problems.push(format!("display window: {bad} pixels differ from the data window placed at its offset"));
        }
    }

    if problems.is_empty() {
        let names: Vec<&str> = channels.iter().map(|c| c["name"].as_str().unwrap()).collect();
        Ok(format!("{w}x{h} {} ({}), part {}", names.join(""), e["mode"].as_str().unwrap(), e["part"]))
    } else {
        Err(problems.join("; "))
    }
}

#[test]
fn fetched_openexr_images_decode_to_openexrs_values_bit_for_bit() {
    let expected: Value = serde_json::from_str(&std::fs::read_to_string(EXPECTED).unwrap()).unwrap();
    let files = expected["files"].as_object().unwrap();
    let dir = images_dir();
    let missing: Vec<&String> = files.keys().filter(|name| !dir.join(name).is_file()).collect();
    if missing.len() == files.len() {
        return common::skip(
            REQUIRE,
            &format!(
                "none of the {} OpenEXR test images is in {} (run scripts/fetch-openexr-images.sh, \
                 or set HDRFLOW_OPENEXR_IMAGES)",
                files.len(),
                dir.display()
            ),
        );
    }

    let mut failures = Vec::new();
    for (name, e) in files {
        let path = dir.join(name);
        let Ok(bytes) = std::fs::read(&path) else {
            say(&format!("missing  {name}: not in {}", dir.display()));
            continue;
        };
        match check(&bytes, e) {
            Ok(summary) => say(&format!("ok       {name}: {summary}, bit for bit")),
            Err(why) => {
                say(&format!("MISMATCH {name}: {why}"));
                failures.push(name.clone());
            }
        }
    }
    say(&format!(
        "exr_fetched_conformance: {} files, {} matched bit for bit, {} mismatched, {} missing",
        files.len(),
        files.len() - failures.len() - missing.len(),
        failures.len(),
        missing.len()
    ));
    assert!(failures.is_empty(), "files that differ from OpenEXR: {failures:?}");
    if !missing.is_empty() {
        common::skip(
            REQUIRE,
            &format!(
                "{} of the {} OpenEXR test images are not in {} and were not checked: {missing:?} \
                 (run scripts/fetch-openexr-images.sh)",
                missing.len(),
                files.len(),
                dir.display()
            ),
        );
    }
}
