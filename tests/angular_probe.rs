//! `AngularToLatLong` against real data: Debevec's angular Grace Cathedral probe, converted with
//! hdrflow's convention (centre column = forward -Z, +X at 3/4 of the width), must match pbrt's
//! independent lat-long remap of the same capture (`grace_latlong.exr`, flipped upright).
//! `../shared/data/envmaps/SOURCES.md` reports a log-luminance correlation of 0.9986 for a
//! remap with this convention; a mirrored or shifted mapping falls far below.

mod common;

use std::path::Path;

use hdrflow::ops::layouts::angular_to_latlong::angular_to_latlong;
use hdrflow::values::Image;

fn load(name: &str) -> Option<Image> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/envmaps").join(name);
    let bytes = std::fs::read(&path).ok()?;
    let ext = path.extension()?.to_string_lossy().to_lowercase();
    Some(hdrflow::formats::decode_by_extension(&bytes, &ext).expect("decodes"))
}

/// Pearson correlation of log(1e-4 + luminance) over the texels away from the poles.
fn log_lum_correlation(a: &Image, b: &Image) -> f64 {
    let lum = |img: &Image, x: usize, y: usize| {
        let [r, g, b] = img.rgb(x, y);
        (1e-4 + 0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64).ln()
    };
    let (w, h) = (a.width, a.height);
    let mut pairs = Vec::new();
    for y in h / 16..h - h / 16 {
        for x in 0..w {
            pairs.push((lum(a, x, y), lum(b, x, y)));
        }
    }
    let n = pairs.len() as f64;
    let (ma, mb) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
    let cov: f64 = pairs.iter().map(|p| (p.0 - ma) * (p.1 - mb)).sum();
    let va: f64 = pairs.iter().map(|p| (p.0 - ma).powi(2)).sum();
    let vb: f64 = pairs.iter().map(|p| (p.1 - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

fn mirrored(img: &Image) -> Image {
    let mut out = img.clone();
    for y in 0..img.height {
        for x in 0..img.width {
            out.pixel_mut(x, y).copy_from_slice(img.pixel(img.width - 1 - x, y));
        }
    }
    out
}

#[test]
fn grace_probe_converts_to_pbrts_lat_long_remap() {
    let (Some(probe), Some(latlong)) = (load("grace_probe.hdr"), load("grace_latlong.exr")) else {
        common::skip_missing_data(
            "../shared/data/envmaps/grace_probe.hdr or grace_latlong.exr not found; AngularToLatLong was not checked against real data",
        );
        return;
    };
    let upright = latlong.flipped_vertical();
    let ours = angular_to_latlong(&probe, upright.width, upright.height);
    let r = log_lum_correlation(&ours, &upright);
    let r_mirrored = log_lum_correlation(&mirrored(&ours), &upright);
    eprintln!("log-luminance correlation: {r:.4} (mirrored: {r_mirrored:.4})");
    assert!(r > 0.99, "correlation {r}");
    assert!(r_mirrored < r - 0.1, "a mirrored mapping correlates almost as well ({r_mirrored} vs {r})");
}
