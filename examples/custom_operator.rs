//! A complete `hdrflow` command line with one extra operator, defined outside the crate.
//!
//!     cargo run --release --example custom_operator -- ops Invert
//!     cargo run --release --example custom_operator -- run examples/invert.ron --out out/invert
//!
//! Everything of the `hdrflow` binary works on it (`run`, `plan`, `dot`, `ops`, `--set`, the
//! cache, `--target`, `--report`), because `hdrflow::cli::main_with` is that binary's command
//! line (without `bench`, the binary's own benchmark) over a registry we hand it. The operator, `Invert(image, white: 1.0)`, replaces every value v
//! by white - v; its parameters are one typed struct, as for the built-in operators.

use hdrflow::engine::fields::{Check, Input};
use hdrflow::engine::op::{OpContext, OpError, OpSpec};
use hdrflow::values::ty::ANY_IMAGE;
use hdrflow::values::Image;
use hdrflow::Value;

// 1. The fields, its input and its parameters: doc comments, accepted types, ranges and
//    defaults become validation, `ops` and the key.
hdrflow::params! {
    pub struct InvertParams {
        /// the image to invert
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// the value that maps to 0
        #[range(0.0, 1e30)]
        pub white: f64 = 1.0,
    }
}

// 2. The operator: name, version (bump it when its output changes), output port (of the
//    input's type), and its source (hashed into the cache key, so an edit to this file never
//    reuses stale results).
fn invert_spec() -> OpSpec {
    OpSpec::new("Invert", "example", 1, "Replace every value v by white - v")
        .output_like("image", |p: InvertParams<Check>| p.image, "the inverted image")
        .code(include_str!("custom_operator.rs"))
        .eval(invert)
}

// 3. Its evaluation: the struct, its input already an image; taken by value, the buffer is
//    reused when this node is its last consumer.
fn invert(_: &mut OpContext, p: InvertParams) -> Result<Value, OpError> {
    let mut img = p.image.take();
    let white = p.white as f32;
    img.data.iter_mut().for_each(|v| *v = white - *v);
    Ok(Value::new(img))
}

fn main() -> std::process::ExitCode {
    // 4. The built-ins plus ours, then the whole command line over them.
    let mut registry = hdrflow::builtin_registry();
    registry.register(invert_spec());
    hdrflow::cli::main_with(registry)
}
