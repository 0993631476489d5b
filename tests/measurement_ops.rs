//! The five measurement operators (ReferenceSphere, ShSphere, ShIrradiance, PerPixelSphere,
//! ImageError) wired in one pipeline (parse, validate, run), under the built-in constant map,
//! where every answer is known: `ReferenceSphere` = albedo, `ShSphere` = albedo,
//! `L_0_0 = 4 pi Y_00 = 2 sqrt(pi)`, `Cosine` per-pixel = albedo exactly.

mod common;

use std::collections::BTreeMap;

use hdrflow::engine::value::Value;
use hdrflow::values::{Image, Metrics, ShCoefficients, ShFrame};

fn run(text: &str, targets: &[&str]) -> Result<BTreeMap<String, Value>, String> {
    common::run_text(text, targets)
}

#[test]
fn measurement_operators_in_a_pipeline() {
    let text = r#"(
nodes: {
    "env":    LoadHdr(path: "builtin:constant"),
    "lum":    Luminance(image: "env"),
    "cdf":    BuildCdf(luminance: "lum"),
    "ref":    ReferenceSphere(env: "env", size: 24, albedo: (0.8, 0.5, 0.25)),
    "sh":     ShSphere(env: "env", size: 24, albedo: (0.8, 0.5, 0.25), order: 2),
    "coeffs": ShIrradiance(env: "env"),
    "pp":     PerPixelSphere(env: "env", cdf: "cdf", size: 24, albedo: (0.8, 0.5, 0.25), strategy: Cosine, spp: 4),
    "mis":    PerPixelSphere(env: "env", cdf: "cdf", size: 24, albedo: (0.8, 0.5, 0.25), strategy: Mis, spp: 4, seed: 3),
    "err":    ImageError(image: "pp", reference: "ref"),
    "err_sh": ImageError(image: "sh", reference: "ref", mask: All),
    "err_mis": ImageError(image: "mis", reference: "ref"),
},
)"#;
    let v = run(text, &["ref", "coeffs", "err", "err_sh", "err_mis"]).expect("runs");
    let reference = v["ref"].get::<Image>().unwrap();
    assert_eq!((reference.width, reference.height, reference.channels), (24, 24, 3));
    let centre = reference.pixel(12, 12);
    for (ch, a) in [0.8f32, 0.5, 0.25].iter().enumerate() {
        // Midpoint rule on the 64 x 32 map: ~(pi/32)^2 / 6 = 1.6e-3 at worst.
        assert!((centre[ch] / a - 1.0).abs() < 2e-3, "{centre:?}");
    }
    let sh = v["coeffs"].get::<ShCoefficients>().unwrap();
    assert_eq!((sh.order, sh.frame, sh.rgb.len()), (2, ShFrame::World, 9));
    // The `metrics` port keeps version 1's flat record (in the chosen frame).
    let coeffs = v["coeffs.metrics"].get::<Metrics>().unwrap();
    assert_eq!(coeffs.fields.len(), 27);
    assert_eq!(coeffs.get("L_0_0_g"), Some(sh.rgb[0][1]));
    assert_eq!(coeffs.fields[0].0, "L_0_0_r");
    assert_eq!(coeffs.fields[3].0, "L_1_-1_r");
    let l00 = coeffs.get("L_0_0_g").unwrap();
    assert!((l00 / (2.0 * std::f64::consts::PI.sqrt()) - 1.0).abs() < 2e-3, "{l00}");
    assert!(coeffs.get("L_2_0_b").unwrap().abs() < 1e-2);

    let err = v["err"].get::<Metrics>().unwrap();
    let disc = err.get("pixels").unwrap();
    assert!(disc > 0.7 * 576.0 && disc < 0.85 * 576.0, "{disc}");
    // Cosine on a constant map is exact; only the reference's midpoint rule differs.
    assert!(err.get("relative_rmse").unwrap() < 2e-3, "{:?}", err.fields);
    let err_sh = v["err_sh"].get::<Metrics>().unwrap();
    assert_eq!(err_sh.get("pixels"), Some(576.0));
    assert!(err_sh.get("relative_rmse").unwrap() < 3e-3, "{:?}", err_sh.fields);
    let err_mis = v["err_mis"].get::<Metrics>().unwrap();
    assert!(err_mis.get("relative_rmse").unwrap() < 0.5, "{:?}", err_mis.fields);
}

#[test]
fn mismatched_distribution_and_non_square_mask_are_errors() {
    let text = r#"(
nodes: {
    "env":  LoadHdr(path: "builtin:constant"),
    "sky":  LoadHdr(path: "builtin:sky"),
    "lum":  Luminance(image: "sky"),
    "cdf":  BuildCdf(luminance: "lum"),
    "pp":   PerPixelSphere(env: "env", cdf: "cdf", size: 8),
    "e":    ImageError(image: "env", reference: "env"),
},
)"#;
    // Both sizes are known before running (built-in maps): refused at validation, with positions.
    let msg = run(text, &["pp"]).expect_err("size mismatch fails");
    assert!(msg.contains("test.ron:7:45: node \"pp\": \"cdf\" is 512x256 but \"env\" is 64x32"), "{msg}");
    // A size only known at run time (a sphere's image is square; a lat-long map is not) is
    // refused when the node runs.
    let text = text.replace("\"pp\":   PerPixelSphere(env: \"env\", cdf: \"cdf\", size: 8),\n", "");
    let msg = run(&text, &["e"]).expect_err("non-square Sphere mask fails");
    assert!(msg.contains("square"), "{msg}");
}
