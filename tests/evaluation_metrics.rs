//! `ImageMetrics` against the protocol's own `fast_rmse.py` functions (vendored verbatim in
//! `bench/peers/fast_rmse_peer.py`), on the same files: the four metrics to 1e-6 relative.
//! Needs the peer Python (`scripts/peer-venv.sh`); skips visibly without it.

mod common;

use common::*;
use hdrflow::values::Image;

/// A prediction, its alpha and a truth with what the metrics must survive: black pixels in
/// either image (the angle's 0/0), a dynamic range of 10^4, pixels off the mask that differ.
fn images(w: usize, h: usize) -> (Image, Image, Image) {
    let hash = |x: usize, y: usize, k: usize| {
        let v = ((x * 73856093) ^ (y * 19349663) ^ (k * 83492791)) % 1000;
        v as f32 / 1000.0
    };
    let gt = Image::from_fn_rgb(w, h, |x, y| {
        let s = 10f32.powf(4.0 * hash(x, y, 9));
        [s * hash(x, y, 0), s * hash(x, y, 1), s * hash(x, y, 2)]
    });
    let mut pred = gt.clone();
    for (i, v) in pred.data.iter_mut().enumerate() {
        *v *= 0.5 + hash(i, 3, 4);
    }
    for i in (0..w * h).step_by(17) {
        pred.data[3 * i..3 * i + 3].fill(0.0);
    }
    let alpha = Image::from_vec(
        w,
        h,
        1,
        (0..w * h).map(|i| if (i / w + i % w).is_multiple_of(5) { 0.0 } else { 1.0 }).collect(),
    );
    (pred, alpha, gt)
}

#[test]
fn image_metrics_equal_fast_rmse_on_the_same_files() {
    let Some(python) = peer_python() else { return };
    let sb = Sandbox::new();
    let (pred, alpha, gt) = images(96, 54);
    sb.write("pred.pfm", hdrflow::formats::pfm::encode(&pred));
    sb.write("alpha.pfm", hdrflow::formats::pfm::encode(&alpha));
    sb.write("gt.pfm", hdrflow::formats::pfm::encode(&gt));
    let graph = sb.write(
        "m.ron",
        r#"(nodes: {
            "pred": LoadHdr(path: "pred.pfm"),
            "alpha": LoadHdr(path: "alpha.pfm"),
            "gt": LoadHdr(path: "gt.pfm"),
            "m": ImageMetrics(pred: "pred", gt: "gt", mask: "alpha"),
            "save": Save(input: "m", path: "m.json"),
        })"#,
    );
    sb.run_ok(&graph, &[]);
    let ours: serde_json::Value = serde_json::from_slice(&read_file(&sb.out().join("m.json"))).unwrap();
    let mut cmd = std::process::Command::new(python);
    cmd.arg(std::path::Path::new(MANIFEST_DIR).join("bench/peers/fast_rmse_peer.py"));
    cmd.args(["pred.pfm", "alpha.pfm", "gt.pfm"].map(|f| sb.join(f)));
    let out = run_command(cmd, std::time::Duration::from_secs(60));
    out.assert_success();
    let theirs: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    for key in ["rmse", "si_rmse", "angular_error_deg", "norm_rmse"] {
        let (a, b) = (ours[key].as_f64().unwrap(), theirs[key].as_f64().unwrap());
        let rel = ((a - b) / b).abs();
        assert!(rel < 1e-6, "{key}: hdrflow {a} vs fast_rmse.py {b} ({rel:e} relative)");
        assert!(a > 0.0, "{key} is {a}: the test images must give every metric a value");
    }
}

#[test]
fn mismatched_sizes_and_a_missing_mask_are_clear() {
    let sb = Sandbox::new();
    let (pred, alpha, gt) = images(8, 4);
    sb.write("pred.pfm", hdrflow::formats::pfm::encode(&pred));
    sb.write("alpha.pfm", hdrflow::formats::pfm::encode(&alpha));
    sb.write("small.pfm", hdrflow::formats::pfm::encode(&images(4, 2).2));
    sb.write("gt.pfm", hdrflow::formats::pfm::encode(&gt));
    let graph = sb.write(
        "bad.ron",
        r#"(nodes: {
            "pred": LoadHdr(path: "pred.pfm"),
            "small": LoadHdr(path: "small.pfm"),
            "m": ImageMetrics(pred: "pred", gt: "small"),
        })"#,
    );
    sb.run(&graph, &[]).0.assert_code(2).assert_stderr_contains("must be the same size");
    // No alpha in a PFM and no mask: every pixel counts, and a warning says so.
    let graph = sb.write(
        "all.ron",
        r#"(nodes: {
            "pred": LoadHdr(path: "pred.pfm"),
            "gt": LoadHdr(path: "gt.pfm"),
            "m": ImageMetrics(pred: "pred", gt: "gt"),
            "save": Save(input: "m", path: "all.json"),
        })"#,
    );
    let (out, _) = sb.run_ok(&graph, &[]);
    out.assert_stderr_contains("every pixel counts");
    let m: serde_json::Value = serde_json::from_slice(&read_file(&sb.out().join("all.json"))).unwrap();
    assert_eq!(m["pixels"].as_f64(), Some(32.0));
}

#[test]
fn protocol_tonemap_equals_the_scripts_tonemap_hdr() {
    let Some(python) = peer_python() else { return };
    let sb = Sandbox::new();
    // A map with black texels (left out of the percentile) and a range of 10^4.
    let (_, _, map) = images(64, 32);
    sb.write("map.pfm", hdrflow::formats::pfm::encode(&map));
    let graph = sb.write(
        "t.ron",
        r#"(nodes: {
            "map": LoadHdr(path: "map.pfm"),
            "t": ProtocolTonemap(image: "map"),
            "save": Save(input: "t", path: "ours.pfm"),
        })"#,
    );
    sb.run_ok(&graph, &[]);
    let mut cmd = std::process::Command::new(python);
    cmd.arg(std::path::Path::new(MANIFEST_DIR).join("bench/peers/tonemap_peer.py"));
    cmd.arg(sb.join("map.pfm")).arg(sb.join("theirs.pfm"));
    run_command(cmd, std::time::Duration::from_secs(60)).assert_success();
    let ours = hdrflow::formats::pfm::decode(&read_file(&sb.out().join("ours.pfm"))).unwrap();
    let theirs = hdrflow::formats::pfm::decode(&read_file(&sb.join("theirs.pfm"))).unwrap();
    assert_eq!((ours.width, ours.height, ours.channels), (theirs.width, theirs.height, theirs.channels));
    let mut worst = 0.0f64;
    for (a, b) in ours.data.iter().zip(&theirs.data) {
        let (a, b) = (*a as f64, *b as f64);
        worst = worst.max((a - b).abs() / b.abs().max(1e-30));
        assert!(a == b || (a - b).abs() <= 1e-6 * b.abs(), "hdrflow {a} vs TonemapHDR {b}");
    }
    assert!(ours.data.iter().any(|&v| v > 0.5), "the test map must reach above the median's 0.5");
    eprintln!("ProtocolTonemap against TonemapHDR: worst relative difference {worst:e}");
}
