//! An operator declared at run time (`OpSpec::field_spec` + `OpSpec::eval_raw`, what the Python
//! bindings build for `hdrflow.operator`): its fields are validated like a Rust operator's, its
//! parameters reach the untyped evaluation, and its results are cached under its code hash.

use std::path::Path;
use std::sync::Arc;

use hdrflow::engine::cache::CacheStore;
use hdrflow::engine::op::{OpContext, OpSpec, OutputType, Outputs};
use hdrflow::engine::params::{Arity, FieldKind, FieldSpec, ParamValue};
use hdrflow::engine::scheduler::{self, NodeStatus, RunOptions, Silent};
use hdrflow::engine::value::Value;
use hdrflow::values::ty::IMAGE_T;
use hdrflow::values::Image;
use hdrflow::Pipeline;

fn scale_spec(code: &str) -> OpSpec {
    OpSpec::new("RuntimeScale", "test", 1, "Multiplies by k (declared at run time)")
        .field_spec(FieldSpec {
            name: "image",
            kind: FieldKind::Input { types: vec![IMAGE_T], arity: Arity::One },
            default: None,
            optional: false,
            doc: "input".into(),
        })
        .field_spec(FieldSpec {
            name: "k",
            kind: FieldKind::Float { min: 0.0, max: 10.0 },
            default: Some(ParamValue::Float(2.0)),
            optional: false,
            doc: "factor".into(),
        })
        .output("out", OutputType::Fixed(IMAGE_T), "scaled")
        .code(code)
        .eval_raw(Arc::new(|ctx: &mut OpContext| {
            let Some(ParamValue::Float(k)) = ctx.params.values.get("k").cloned() else { unreachable!() };
            let input = std::mem::take(&mut ctx.inputs).into_iter().find(|(f, _)| *f == "image");
            let value = input.and_then(|(_, v)| v.into_iter().next()).expect("validated: wired");
            let mut img: Image = value.take().expect("validated: an image");
            img.data.iter_mut().for_each(|v| *v *= k as f32);
            Ok(Outputs::from(Value::new(img)))
        }))
}

fn run_with(code: &str, text: &str, cache: &Path) -> scheduler::RunOutcome {
    let mut registry = hdrflow::builtin_registry();
    registry.register(scale_spec(code)).unwrap();
    let p = Pipeline::parse(text, "t.ron", Path::new("."), &registry, &[]).expect("validates");
    let options = RunOptions {
        targets: vec!["s".into()],
        out_dir: cache.join("out"),
        cache: Some(CacheStore::new(cache, 1 << 30)),
        jobs: Some(2),
        observer: &Silent,
    };
    scheduler::run(&p, &options).expect("runs")
}

#[test]
fn a_runtime_declared_operator_is_validated_run_and_cached_by_its_code() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"(nodes: { "c": Constant(width: 2, height: 1, color: 1.5), "s": RuntimeScale(image: "c") })"#;
    let first = run_with("v1", text, dir.path());
    assert_eq!(first.values["s"].get::<Image>().unwrap().data, vec![3.0; 6]);
    assert_eq!(run_with("v1", text, dir.path()).report.status_of("s"), Some(NodeStatus::Cached));
    assert_eq!(run_with("v2", text, dir.path()).report.status_of("s"), Some(NodeStatus::Computed));

    let mut registry = hdrflow::builtin_registry();
    registry.register(scale_spec("v1")).unwrap();
    let bad =
        r#"(nodes: { "c": Constant(width: 2, height: 1, color: 1.5), "s": RuntimeScale(image: "c", k: 11.0, q: 1) })"#;
    let errors = Pipeline::parse(bad, "t.ron", Path::new("."), &registry, &[]).unwrap_err().to_string();
    assert!(errors.contains("t.ron:1:") && errors.contains("\"k\"") && errors.contains("\"q\""), "{errors}");
}
