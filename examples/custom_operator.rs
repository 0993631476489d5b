//! A complete `hdrflow` command line with one extra operator, defined outside the crate.
//!
//!     cargo run --release --example custom_operator -- ops Invert
//!     cargo run --release --example custom_operator -- run examples/invert.ron --out out/invert
//!
//! Everything of the `hdrflow` binary works on it (`run`, `plan`, `dot`, `ops`, `--set`, the
//! cache, `--target`, `--report`), because `hdrflow::cli::main_with` is that binary's command
//! line (without `bench`, the binary's own benchmark) over a registry we hand it. The operator, `Invert(image, white: 1.0)`, replaces every value v
//! by white - v; its parameters are one typed struct, as for the built-in operators.

use hdrflow::engine::fields::Input;
use hdrflow::engine::op::{OpContext, OpError, OpSpec};
use hdrflow::engine::typed_op::Op;
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

// 2. The operator: name, version (bump it when its output changes), its evaluation (which
//    fixes the struct every later call is typed by), output port (of the input's type), and its
//    source (hashed into the cache key, so an edit to this file never reuses stale results).
//    Its category in `hdrflow ops` is the crate's name, `custom_operator`.
fn invert_spec() -> OpSpec {
    Op::new("Invert", 1, "Replace every value v by white - v", invert)
        .output_like("image", |p| p.image, "the inverted image")
        .spec()
        .code(include_str!("custom_operator.rs"))
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
    if let Err(e) = registry.register(invert_spec()) {
        eprintln!("error: {e}");
        return std::process::ExitCode::FAILURE;
    }
    hdrflow::cli::main_with(registry)
}
