//! `ReferenceSphere(env, size: 256, albedo, view)`: the exact answer for the relit diffuse
//! sphere, `Lo(n) = (albedo / pi) sum_texels L dOmega max(n.d, 0)` at every pixel of the disc
//! (`maths::reference`), 0 elsewhere. Same `size`, `albedo` and `view` fields and defaults as
//! `RelightSphere`, so the images compare pixel for pixel (e.g. with `ImageError`): the
//! expectation of `RelightSphere` with `Unbiased` samples from `Sample` is exactly this image
//! (up to f32 rounding).
//!
//! Cost: O(pixels x lit texels), a brute-force sum made fast by culling and SIMD (a 256 x 256
//! sphere under a 1024 x 512 map takes ~1-2 s on 2 cores).

use super::{ALBEDO_FIELD, SIZE_FIELD, VIEW_FIELD};
use crate::engine::op::{FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;
use crate::maths::reference::{first_non_finite, reference_sphere};
use crate::maths::relight::SphereView;

pub static SPEC: OpSpec = OpSpec {
    name: "ReferenceSphere",
    category: "shading",
    version: 1,
    doc: "The exact relit diffuse sphere: (albedo/pi) * sum over every texel of L dOmega max(n.d, 0)",
    fields: &[
        FieldSpec::input("env", &[ValueType::Image], "the lat-long environment (linear RGB)"),
        SIZE_FIELD,
        ALBEDO_FIELD,
        VIEW_FIELD,
    ],
    output: OutputType::Fixed(ValueType::Image),
    eval,
    content_key: None,
    check: None,
};

/// An error naming the first NaN or infinite texel of `env`, if any (shared by the shading
/// operators that sum over the whole map).
pub(crate) fn check_finite(env: &crate::data::Image) -> Result<(), OpError> {
    match first_non_finite(env) {
        Some((x, y, v)) => Err(OpError::Invalid(format!(
            "texel ({x}, {y}) of the environment is {v}: an exact sum needs finite radiance"
        ))),
        None => Ok(()),
    }
}

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let env = ctx.image("env");
    check_finite(env)?;
    let size = ctx.params.usize("size");
    let albedo = ctx.params.vec3("albedo");
    let [vt, vp] = ctx.params.vec2("view");
    let view = SphereView::new(size, latlong::direction_deg(vt, vp));
    Ok(Value::image(reference_sphere(env, &view, albedo)))
}

/// The five measurement operators wired in one pipeline (parse, validate, run), under the
/// built-in constant map, where every answer is known: `ReferenceSphere` = albedo, `ShSphere` =
/// albedo, `L_0_0 = 4 pi Y_00 = 2 sqrt(pi)`, `Cosine` per-pixel = albedo exactly.
#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::path::Path;

    use crate::engine::graph::Pipeline;
    use crate::engine::registry::Registry;
    use crate::engine::scheduler::{self, RunOptions, Silent};
    use crate::engine::value::Value;

    fn run(text: &str, targets: &[&str]) -> Result<BTreeMap<String, Value>, String> {
        let registry = Registry::with_builtins();
        let p = Pipeline::parse(text, "test.ron", Path::new("."), &registry, &[]).map_err(|e| e.to_string())?;
        let out = std::env::temp_dir().join(format!("hdrflow-reference-sphere-test-{}", std::process::id()));
        let options = RunOptions {
            targets: targets.iter().map(|t| t.to_string()).collect(),
            out_dir: out,
            cache: None,
            jobs: Some(2),
            observer: &Silent,
        };
        scheduler::run(&p, &options).map(|o| o.values).map_err(|e| e.to_string())
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
        let reference = v["ref"].as_image().unwrap();
        assert_eq!((reference.width, reference.height, reference.channels), (24, 24, 3));
        let centre = reference.pixel(12, 12);
        for (ch, a) in [0.8f32, 0.5, 0.25].iter().enumerate() {
            // Midpoint rule on the 64 x 32 map: ~(pi/32)^2 / 6 = 1.6e-3 at worst.
            assert!((centre[ch] / a - 1.0).abs() < 2e-3, "{centre:?}");
        }
        let coeffs = v["coeffs"].as_metrics().unwrap();
        assert_eq!(coeffs.fields.len(), 27);
        assert_eq!(coeffs.fields[0].0, "L_0_0_r");
        assert_eq!(coeffs.fields[3].0, "L_1_-1_r");
        let l00 = coeffs.get("L_0_0_g").unwrap();
        assert!((l00 / (2.0 * std::f64::consts::PI.sqrt()) - 1.0).abs() < 2e-3, "{l00}");
        assert!(coeffs.get("L_2_0_b").unwrap().abs() < 1e-2);

        let err = v["err"].as_metrics().unwrap();
        let disc = err.get("pixels").unwrap();
        assert!(disc > 0.7 * 576.0 && disc < 0.85 * 576.0, "{disc}");
        // Cosine on a constant map is exact; only the reference's midpoint rule differs.
        assert!(err.get("relative_rmse").unwrap() < 2e-3, "{:?}", err.fields);
        let err_sh = v["err_sh"].as_metrics().unwrap();
        assert_eq!(err_sh.get("pixels"), Some(576.0));
        assert!(err_sh.get("relative_rmse").unwrap() < 3e-3, "{:?}", err_sh.fields);
        let err_mis = v["err_mis"].as_metrics().unwrap();
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
        let msg = run(text, &["pp"]).expect_err("size mismatch fails");
        assert!(msg.contains("distribution"), "{msg}");
        let msg = run(text, &["e"]).expect_err("non-square Sphere mask fails");
        assert!(msg.contains("square"), "{msg}");
    }
}
