//! Spherical Gaussians (issue 26) end to end: `SphericalGaussians` and `SgToLatLong` through
//! real RON pipelines. Closed forms: a map that is one lobe gives that lobe back; a rendered
//! lobe integrates to `2 pi a (1 - exp(-2 lambda)) / lambda`; the relative RMSE never grows
//! with iterations, nor (on `builtin:sky`) with lobes; a fixed seed gives bit-identical output;
//! degenerate maps give finite lobes; bad fields and NaN texels are errors naming the node.

mod common;

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;
use std::time::Instant;

use glam::DVec3;
use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::engine::value::Value;
use hdrflow::geometry::latlong;
use hdrflow::maths::fit::spherical_gaussians::render;
use hdrflow::maths::resample::layouts::latlong_integral;
use hdrflow::values::{Image, Metrics, SgLobe, SphericalGaussians};

/// Runs `text` (its `Save` nodes writing into `out`), with `provided` values in place of nodes.
fn run_with(
    text: &str,
    provided: Vec<(&str, Value)>,
    out: &Path,
    targets: &[&str],
) -> Result<BTreeMap<String, Value>, String> {
    let registry = hdrflow::builtin_registry();
    let mut p =
        hdrflow::Pipeline::parse(text, "test.ron", Path::new("."), &registry, &[]).map_err(|e| e.to_string())?;
    for (node, value) in provided {
        p.provide(node, value)?;
    }
    let options = RunOptions {
        targets: targets.iter().map(|t| t.to_string()).collect(),
        out_dir: out.to_path_buf(),
        cache: None,
        jobs: Some(2),
        observer: &Silent,
    };
    scheduler::run(&p, &options).map(|o| o.values).map_err(|e| e.to_string())
}

fn run(text: &str, targets: &[&str]) -> Result<BTreeMap<String, Value>, String> {
    common::run_text(text, targets)
}

fn sg<'a>(v: &'a BTreeMap<String, Value>, node: &str) -> &'a SphericalGaussians {
    v[node].get::<SphericalGaussians>().unwrap_or_else(|| panic!("{node} is not sg"))
}

fn metric(v: &BTreeMap<String, Value>, node: &str, field: &str) -> f64 {
    let m = v[&format!("{node}.metrics")].get::<Metrics>().unwrap_or_else(|| panic!("{node}.metrics"));
    m.get(field).unwrap_or_else(|| panic!("{node}: no {field} in {:?}", m.fields))
}

/// The angle between unit vectors, accurate near 0.
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (a, b) = (DVec3::from(a), DVec3::from(b));
    a.cross(b).length().atan2(a.dot(b))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// A graph whose lobe "truth" (one lobe fitted to a tilted hemisphere) is rendered and fitted.
const ROUND_TRIP: &str = r#"(
nodes: {
    "hemi":  LoadHdr(path: "builtin:hemisphere"),
    "tilted": Rotate(image: "hemi", yaw: 30, pitch: 20),
    "truth": SphericalGaussians(env: "tilted", lobes: 1, iterations: 10),
    "map":   SgToLatLong(lobes: "truth", width: 256, height: 128),
    "big":   SgToLatLong(lobes: "truth", width: 1024, height: 512),
    "fit":   SphericalGaussians(env: "map", lobes: 1, iterations: 60),
    "fit_big": SphericalGaussians(env: "big", lobes: 1, iterations: 60),
    "save":  Save(input: "fit", path: "lobes.json"),
    "chosen": Constant(width: 256, height: 128),
    "fit_chosen": SphericalGaussians(env: "chosen", lobes: 1, iterations: 60),
},
)"#;

#[test]
fn one_lobe_comes_back_and_a_rendered_lobe_integrates_to_the_closed_form() {
    let out = std::env::temp_dir().join(format!("hdrflow-sg-{}", std::process::id()));
    // "chosen" is replaced by a map that is exactly a sharper lobe of our choosing.
    let chosen = SgLobe { axis: latlong::direction_deg(70.0, 300.0), sharpness: 45.0, amplitude: [3.0, 2.0, 1.0] };
    let chosen_map = render(&SphericalGaussians { lobes: vec![chosen.clone()] }, 256, 128);
    let targets = ["truth", "map", "big", "fit", "fit_big", "save", "fit_chosen"];
    let v = run_with(ROUND_TRIP, vec![("chosen", Value::new(chosen_map))], &out, &targets).expect("runs");
    let truth = sg(&v, "truth").lobes[0].clone();
    eprintln!("truth: {truth:?}");
    assert!(truth.sharpness > 0.1 && truth.amplitude.iter().all(|a| *a > 0.0), "{truth:?}");

    // The map's midpoint integral is the closed form, to twice the grid's own excess over 4 pi
    // (pi^2 / 24 H^2: 2.5e-5 at H = 128; measured 3.4e-5 for this broad lobe).
    let map = v["map"].get::<Image>().unwrap();
    assert_eq!((map.width, map.height, map.channels), (256, 128, 3));
    let want = truth.integral();
    for (c, got) in latlong_integral(map).iter().enumerate() {
        let e = rel(*got, want[c]);
        assert!(e < 2.0 * PI * PI / (24.0 * 128.0 * 128.0), "channel {c}: {got} vs {} ({e:e})", want[c]);
        let l = truth.sharpness;
        assert!((want[c] / (2.0 * PI * truth.amplitude[c] * (1.0 - (-2.0 * l).exp()) / l) - 1.0).abs() < 1e-14);
    }

    // Fitted at its own resolution: the lobe itself (f32 rounding of the map; measured 1e-9).
    for (node, want) in [("fit", &truth), ("fit_chosen", &chosen)] {
        let got = &sg(&v, node).lobes[0];
        let a = angle(got.axis, want.axis);
        eprintln!("{node}: axis {a:.1e} rad, sharpness {:.1e}", rel(got.sharpness, want.sharpness));
        assert!(a < 1e-7, "{node}: axis off by {a} rad (the issue asks for 1e-3)");
        assert!(rel(got.sharpness, want.sharpness) < 1e-7, "{node}: {got:?}");
        for c in 0..3 {
            assert!(rel(got.amplitude[c], want.amplitude[c]) < 1e-7, "{node}: {got:?}");
        }
        assert!(metric(&v, node, "relative_rmse") < 1e-7);
        assert_eq!((metric(&v, node, "fit_width"), metric(&v, node, "fit_height")), (256.0, 128.0));
    }
    let got = &sg(&v, "fit").lobes[0];

    // From 1024 x 512, fitted on its 4 x 4 block means: no longer exactly a lobe (each block
    // mean averages the lobe's point values over 1.4 degrees, the fit its mean): measured
    // 1.3e-6 rad and 5e-6 relative (2e-5 and 8e-5 when the fit took point values).
    let big = &sg(&v, "fit_big").lobes[0];
    let a = angle(big.axis, truth.axis);
    eprintln!(
        "one lobe from 1024 x 512: axis {a:.1e} rad, sharpness {:.1e}, amplitude {:.1e}, rmse {:.1e}",
        rel(big.sharpness, truth.sharpness),
        rel(big.amplitude[0], truth.amplitude[0]),
        metric(&v, "fit_big", "relative_rmse")
    );
    assert!(a < 1e-4, "{big:?}");
    assert!(rel(big.sharpness, truth.sharpness) < 1e-3 && rel(big.amplitude[0], truth.amplitude[0]) < 1e-3, "{big:?}");
    assert_eq!(metric(&v, "fit_big", "fit_width"), 256.0);

    // The saved file: exactly the keys of the issue, the same numbers.
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("lobes.json")).expect("saved")).expect("JSON");
    assert_eq!(json.as_object().unwrap().keys().collect::<Vec<_>>(), ["lobes"]);
    let lobe = &json["lobes"][0];
    assert_eq!(lobe.as_object().unwrap().keys().collect::<Vec<_>>(), ["axis", "sharpness", "amplitude"]);
    assert_eq!(lobe["sharpness"].as_f64(), Some(got.sharpness));
    assert_eq!(lobe["axis"][1].as_f64(), Some(got.axis[1]));
    assert_eq!(lobe["amplitude"][2].as_f64(), Some(got.amplitude[2]));
    let _ = std::fs::remove_dir_all(&out);
}

/// A lat-long map whose texel holds the lobe's mean over it: a 5 x 5 Gauss-Legendre rule in
/// `theta x phi` per texel, weighted by `sin theta` (at 1024 x 512 and lambda 1000, 1e-12 of
/// the peak).
fn texel_mean_map(lobe: &SgLobe, w: usize, h: usize) -> Image {
    const X: [f64; 5] =
        [-0.906_179_845_938_664, -0.538_469_310_105_683_1, 0.0, 0.538_469_310_105_683_1, 0.906_179_845_938_664];
    const W: [f64; 5] = [
        0.236_926_885_056_189_1,
        0.478_628_670_499_366_5,
        0.568_888_888_888_888_9,
        0.478_628_670_499_366_5,
        0.236_926_885_056_189_1,
    ];
    let (dt, dp) = (PI / h as f64, 2.0 * PI / w as f64);
    Image::from_fn_rgb(w, h, |x, y| {
        let (mut sum, mut weight) = (0.0, 0.0);
        for (u, wu) in X.iter().zip(W) {
            let theta = (y as f64 + 0.5 + 0.5 * u) * dt;
            for (v, wv) in X.iter().zip(W) {
                let phi = (x as f64 + 0.5 + 0.5 * v) * dp;
                sum += wu * wv * theta.sin() * lobe.kernel(latlong::direction(theta, phi));
                weight += wu * wv * theta.sin();
            }
        }
        lobe.amplitude.map(|a| (a * sum / weight) as f32)
    })
}

/// Issue 39: one lobe of sharpness 10 to 1000 on a random axis, as a 1024 x 512 map of texel
/// means, fitted on its 256 x 128 block means (which are then the lobe's means over the fit
/// texels): sharpness and amplitude within 1e-3 relative, the axis within 1e-4 rad (measured
/// 3e-10 to 2e-9 and 1e-10 rad). Fitting the lobe's values at the fit texels' centres instead
/// (version 1) gave -4.8e-3 at lambda 100 and -4.1e-2 at 1000.
#[test]
fn sharp_lobes_of_texel_means_are_fitted_without_bias() {
    let out = std::env::temp_dir().join(format!("hdrflow-sg-means-{}", std::process::id()));
    let text = r#"(nodes: {
    "map": Constant(width: 1024, height: 512),
    "fit": SphericalGaussians(env: "map", lobes: 1, iterations: 60),
})"#;
    let mut rng = hdrflow::maths::sampling::sequences::SplitMix64::new(39);
    for lambda in [10.0, 100.0, 300.0, 1000.0] {
        let (z, phi) = (2.0 * rng.next_f64() - 1.0, 2.0 * PI * rng.next_f64());
        let r = (1.0 - z * z).sqrt();
        let truth = SgLobe { axis: [r * phi.cos(), z, r * phi.sin()], sharpness: lambda, amplitude: [3.0, 2.0, 1.0] };
        let map = texel_mean_map(&truth, 1024, 512);
        let v = run_with(text, vec![("map", Value::new(map))], &out, &["fit"]).expect("runs");
        let got = &sg(&v, "fit").lobes[0];
        let (a, s) = (angle(got.axis, truth.axis), got.sharpness / lambda - 1.0);
        let amp: Vec<f64> = (0..3).map(|c| got.amplitude[c] / truth.amplitude[c] - 1.0).collect();
        eprintln!("lambda {lambda}: sharpness {s:+.1e}, amplitude {:+.1e}, axis {a:.1e} rad", amp[0]);
        assert!(s.abs() <= 1e-3 && amp.iter().all(|e| e.abs() <= 1e-3), "lambda {lambda}: {got:?}");
        assert!(a < 1e-4, "lambda {lambda}: axis off by {a} rad");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn rmse_never_grows_with_iterations_or_lobes_and_a_seed_is_deterministic() {
    let text = r#"(
nodes: {
    "sky":  LoadHdr(path: "builtin:sky"),
    "i0":   SphericalGaussians(env: "sky", lobes: 4, iterations: 0),
    "i1":   SphericalGaussians(env: "sky", lobes: 4, iterations: 1),
    "i3":   SphericalGaussians(env: "sky", lobes: 4, iterations: 3),
    "i10":  SphericalGaussians(env: "sky", lobes: 4, iterations: 10),
    "i30":  SphericalGaussians(env: "sky", lobes: 4, iterations: 30),
    "n1":   SphericalGaussians(env: "sky", lobes: 1),
    "n2":   SphericalGaussians(env: "sky", lobes: 2),
    "n8":   SphericalGaussians(env: "sky", lobes: 8),
    "n16":  SphericalGaussians(env: "sky", lobes: 16),
    "s7":   SphericalGaussians(env: "sky", lobes: 8, seed: 7),
    "s7b":  SphericalGaussians(env: "sky", lobes: 8, seed: 7),
    "back": SgToLatLong(lobes: "n16", width: 512, height: 256),
},
)"#;
    let targets = ["i0", "i1", "i3", "i10", "i30", "n1", "n2", "n8", "n16", "s7", "s7b", "back"];
    let v = run(text, &targets).expect("runs");
    let rmse = |n: &str| metric(&v, n, "relative_rmse");
    let by_iterations: Vec<f64> = ["i0", "i1", "i3", "i10", "i30"].iter().map(|n| rmse(n)).collect();
    let by_lobes: Vec<f64> = ["n1", "n2", "i30", "n8", "n16"].iter().map(|n| rmse(n)).collect();
    eprintln!("builtin:sky, 4 lobes, 0/1/3/10/30 iterations: {by_iterations:.4?}");
    eprintln!("builtin:sky, 30 iterations, 1/2/4/8/16 lobes: {by_lobes:.4?}");
    assert!(by_iterations.windows(2).all(|w| w[1] <= w[0]), "{by_iterations:?}");
    assert!(by_lobes.windows(2).all(|w| w[1] <= w[0]), "{by_lobes:?}");
    // And they do improve: the start (matching pursuit) is well above the fit.
    assert!(by_iterations[4] < 0.5 * by_iterations[0] && by_lobes[4] < 0.5 * by_lobes[0]);
    for (n, asked) in [("i0", 0.0), ("i3", 3.0), ("i30", 30.0)] {
        assert!(metric(&v, n, "iterations") <= asked);
    }
    assert_eq!(metric(&v, "i3", "iterations"), 3.0);

    // A fixed seed: bit-identical lobes and metrics, here and in another run.
    assert_eq!(sg(&v, "s7"), sg(&v, "s7b"));
    assert_ne!(sg(&v, "s7"), sg(&v, "n8"), "the seed moves the start");
    let again = run(text, &["s7", "n16", "back"]).expect("runs again");
    for n in ["s7", "n16"] {
        assert_eq!(sg(&again, n), sg(&v, n), "{n}");
        assert_eq!(metric(&again, n, "relative_rmse").to_bits(), rmse(n).to_bits(), "{n}");
    }
    assert_eq!(again["back"].get::<Image>().unwrap().data, v["back"].get::<Image>().unwrap().data);

    let back = v["back"].get::<Image>().unwrap();
    assert!(back.data.iter().all(|x| x.is_finite() && *x >= 0.0));
    let lobes = sg(&v, "n16");
    assert_eq!(lobes.lobes.len(), 16);
    // Most energetic first (Rec. 709 luminance of each lobe's integral).
    let energy = |l: &SgLobe| hdrflow::colour::rec709_luminance(l.integral().map(|x| x as f32));
    assert!(lobes.lobes.windows(2).all(|w| energy(&w[0]) >= energy(&w[1])), "{lobes:?}");
}

#[test]
fn the_park_map_twelve_lobes() {
    let text = r#"(
nodes: {
    "park": LoadHdr(path: "assets/maps/rooitou_park_1k.hdr"),
    "n1":   SphericalGaussians(env: "park", lobes: 1),
    "n4":   SphericalGaussians(env: "park", lobes: 4),
    "fit":  SphericalGaussians(env: "park"),
},
)"#;
    let start = Instant::now();
    let v = run(text, &["park"]).expect("loads");
    let load = start.elapsed();
    let start = Instant::now();
    let v12 = run(text, &["fit"]).expect("runs");
    let time = start.elapsed().saturating_sub(load);
    let v = {
        let mut all = run(text, &["n1", "n4"]).expect("runs");
        all.extend(v12);
        all.extend(v);
        all
    };
    let rmse: Vec<f64> = ["n1", "n4", "fit"].iter().map(|n| metric(&v, n, "relative_rmse")).collect();
    eprintln!("park: relative RMSE for 1/4/12 lobes {rmse:.5?}; 12 lobes in {time:.2?} (load {load:.2?})");
    assert!(rmse.windows(2).all(|w| w[1] <= w[0]), "{rmse:?}");
    assert!(rmse[2] < 0.3, "{rmse:?}");
    let lobes = sg(&v, "fit");
    assert_eq!(lobes.lobes.len(), 12);
    assert_eq!((metric(&v, "fit", "fit_width"), metric(&v, "fit", "fit_height")), (256.0, 128.0));
    // The brightest lobe is on the sun (the map's brightest texel), within a fit texel.
    let park = v["park"].get::<Image>().unwrap();
    let (mut best, mut at) = (0.0, (0, 0));
    for y in 0..park.height {
        for x in 0..park.width {
            let l = hdrflow::colour::rec709_luminance(park.rgb(x, y));
            if l > best {
                (best, at) = (l, (x, y));
            }
        }
    }
    let sun = latlong::texel_direction(at.0, at.1, park.width, park.height);
    assert!(angle(lobes.lobes[0].axis, sun) < PI / 128.0, "{:?} vs {sun:?}", lobes.lobes[0]);
}

#[test]
fn degenerate_maps_and_bad_input() {
    let out = std::env::temp_dir().join(format!("hdrflow-sg-bad-{}", std::process::id()));
    // Black and constant maps through RON; one hot texel provided.
    let text = r#"(
nodes: {
    "black": Constant(width: 64, height: 32),
    "grey":  Constant(width: 64, height: 32, color: (0.5, 1.0, 2.0)),
    "hot":   Constant(width: 64, height: 32),
    "f_black": SphericalGaussians(env: "black", lobes: 3),
    "f_grey":  SphericalGaussians(env: "grey", lobes: 3),
    "f_hot":   SphericalGaussians(env: "hot", lobes: 3),
    "r_hot":   SgToLatLong(lobes: "f_hot", width: 64, height: 32),
},
)"#;
    let mut hot = Image::new(64, 32, 3);
    hot.pixel_mut(10, 3).copy_from_slice(&[1e5, 1e5, 1e5]);
    let v =
        run_with(text, vec![("hot", Value::new(hot))], &out, &["f_black", "f_grey", "f_hot", "r_hot"]).expect("runs");
    for n in ["f_black", "f_grey", "f_hot"] {
        let r = metric(&v, n, "relative_rmse");
        assert!(r.is_finite() && r <= 1.0, "{n}: {r}");
        for l in &sg(&v, n).lobes {
            let finite = l.axis.iter().chain(&l.amplitude).chain([&l.sharpness]).all(|x| x.is_finite());
            assert!(finite && l.sharpness > 0.0 && l.amplitude.iter().all(|a| *a >= 0.0), "{n}: {l:?}");
        }
    }
    assert_eq!(metric(&v, "f_black", "relative_rmse"), 0.0);
    assert!(metric(&v, "f_grey", "relative_rmse") < 0.05);
    assert!(v["r_hot"].get::<Image>().unwrap().data.iter().all(|x| x.is_finite()));

    // NaN texels: a run error naming the node.
    let mut nan = Image::new(16, 8, 3);
    nan.pixel_mut(3, 2)[1] = f32::NAN;
    let msg = run_with(text, vec![("hot", Value::new(nan))], &out, &["f_hot"]).expect_err("NaN");
    eprintln!("NaN: {msg}");
    assert!(msg.contains("f_hot") && msg.contains("texel (3, 2)") && msg.contains("NaN"), "{msg}");

    // Bad fields: positioned pipeline errors before anything runs.
    for (node, want) in [
        (r#"SphericalGaussians(env: "sky", lobes: 0)"#, r#"node "x": field "lobes": 0 is out of range"#),
        (r#"SphericalGaussians(env: "sky", lobes: 257)"#, r#"node "x": field "lobes": 257 is out of range"#),
        (r#"SphericalGaussians(env: "sky", iterations: -1)"#, r#"node "x": field "iterations""#),
        (r#"SgToLatLong(lobes: "sky")"#, r#"node "x""#),
        (r#"SgToLatLong(lobes: "fit", width: 0)"#, r#"node "x": field "width": 0 is out of range"#),
    ] {
        let text = format!(
            "(nodes: {{ \"sky\": LoadHdr(path: \"builtin:sky\"), \"fit\": SphericalGaussians(env: \"sky\"), \"x\": {node} }})"
        );
        let msg = run(&text, &["x"]).expect_err(node);
        assert!(msg.contains(want), "{node}:\n{msg}\nwanted: {want}");
        assert!(msg.contains("test.ron:1:"), "{node}: a position: {msg}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_example_graph_runs_and_saves_what_the_docs_say() {
    let registry = hdrflow::builtin_registry();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/spherical_gaussians.ron");
    let p = hdrflow::Pipeline::load(&path, &registry, &[]).expect("graphs/spherical_gaussians.ron is valid");
    let out = tempfile::tempdir().unwrap();
    let options = RunOptions {
        targets: p.nodes.iter().map(|n| n.name.clone()).collect(),
        out_dir: out.path().into(),
        cache: None,
        jobs: Some(2),
        observer: &Silent,
    };
    let v = scheduler::run(&p, &options).expect("runs").values;
    assert_eq!(sg(&v, "sg").lobes.len(), 12);
    assert!(metric(&v, "sg", "relative_rmse") < 0.06, "{}", metric(&v, "sg", "relative_rmse"));
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.path().join("sg/fit.json")).unwrap()).unwrap();
    let keys: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    assert_eq!(keys, ["relative_rmse", "iterations", "fit_width", "fit_height"]);
    for file in ["sg/lobes.json", "sg/preview.exr", "sg/relative_error.png"] {
        assert!(out.path().join(file).exists(), "{file}");
    }
}
