//! Defining an operator outside hdrflow, registering it, and running a pipeline file that uses it.
//!
//!     cargo run --example custom_operator
//!
//! The operator, `Invert(image, white: 1.0)`, replaces every value v by white - v.

use std::sync::Arc;

use hdrflow::data::Image;
use hdrflow::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::{Pipeline, Registry, Value, ValueType};

/// 1. Declare the operator: name, version (bump it when its output changes), fields, output.
static INVERT: OpSpec = OpSpec {
    name: "Invert",
    category: "example",
    version: 1,
    doc: "Replace every value v by white - v",
    fields: &[
        FieldSpec::input("image", &[ValueType::Image, ValueType::ScalarField], "the image to invert"),
        FieldSpec {
            name: "white",
            kind: FieldKind::Float { min: 0.0, max: 1e30 },
            default: Default::Float(1.0),
            doc: "the value that maps to 0",
        },
    ],
    output: OutputType::SameAsInput("image"),
    eval: invert,
    content_key: None,
    check: None,
};

/// 2. Its evaluation: typed getters read the validated fields and inputs.
fn invert(ctx: &OpContext) -> Result<Value, OpError> {
    let img = ctx.image("image");
    let white = ctx.params.f64("white") as f32;
    let data = img.data.iter().map(|v| white - v).collect();
    Ok(Value::Image(Arc::new(Image::from_vec(img.width, img.height, img.channels, data))))
}

const PIPELINE: &str = r#"(
    nodes: {
        "canvas": Constant(width: 4, height: 2, color: (0.25, 0.5, 1.0)),
        "inv":    Invert(image: "canvas", white: 2.0),
        "save":   Save(input: "inv", path: "inverted.pfm"),
    },
)"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // 3. Register it beside the built-ins.
    let mut registry = Registry::with_builtins();
    registry.register(&INVERT);

    // 4. Parse, validate and run a pipeline that uses it.
    let pipeline = Pipeline::parse(PIPELINE, "custom.ron", ".".as_ref(), &registry, &[])?;
    let out_dir = std::env::temp_dir().join(format!("hdrflow-custom-operator-{}", std::process::id()));
    let options = RunOptions { targets: vec![], out_dir: out_dir.clone(), cache: None, jobs: None, observer: &Silent };
    let outcome = scheduler::run(&pipeline, &options)?;

    let written = std::fs::read(out_dir.join("inverted.pfm"))?;
    let image = hdrflow::formats::pfm::decode(&written)?;
    println!("Invert(white: 2.0) of (0.25, 0.5, 1.0) = {:?}", image.rgb(0, 0));
    assert_eq!(image.rgb(0, 0), [1.75, 1.5, 1.0]);
    println!(
        "ran {} nodes in {:.2} ms; wrote {}",
        outcome.report.nodes.len(),
        outcome.report.total_ms,
        out_dir.join("inverted.pfm").display()
    );
    std::fs::remove_dir_all(&out_dir)?;
    Ok(())
}
