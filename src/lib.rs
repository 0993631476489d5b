//! hdrflow: a node-graph engine for HDR image processing.
//!
//! Layers, each using only those below it:
//! - [`cli`]: the command line, over any registry (`cli::main_with`); the `hdrflow` binary adds
//!   `bench`, the benchmark, which is its own module (src/bench), not the library's.
//! - [`report`]: the HTML page of a run (graph, outputs, nodes, timeline).
//! - [`ibl_presets`]: each engine's image-based-lighting conventions and its bake pipeline
//!   (`hdrflow bake`).
//! - [`ops`]: the built-in operators, one file each, grouped by domain; `ops::builtin_registry`.
//! - [`values`], [`maths`], [`formats`], [`plotting`]: the built-in value types (each data type
//!   with its name in graphs and its cache codec, declared to the engine), mathematics, file
//!   formats (with `Save`'s encoders of every value type, `formats::save`), plots. `formats`,
//!   `maths` and `plotting` build on `values`, which imports none of them.
//! - [`engine`]: pipeline files, validation, the parallel demand-driven scheduler, the cache;
//!   it knows no operator and no value type.
//! - [`geometry`]: the lat-long and cube conventions, below all of them (it depends on nothing
//!   but [`choice`]);
//!   [`cpu`]: the instruction-set level every SIMD path runs at (`HDRFLOW_CPU`); [`choice`]: the
//!   one way to declare an enum that pipelines choose by name; [`colour`]: the Rec. 709 luminance
//!   weights that maths, formats and operators share.
//!
//! Running a pipeline from code:
//! ```no_run
//! use hdrflow::engine::{graph::Pipeline, scheduler};
//! let registry = hdrflow::ops::builtin_registry();
//! let pipeline = Pipeline::load("graphs/example.ron".as_ref(), &registry, &[]).unwrap();
//! let options = scheduler::RunOptions {
//!     targets: vec![],
//!     out_dir: "out".into(),
//!     cache: None,
//!     jobs: None,
//!     observer: &scheduler::Silent,
//! };
//! let outcome = scheduler::run(&pipeline, &options).unwrap();
//! println!("{} ms", outcome.report.total_ms);
//! ```

// `!(x > 0.0)` is written on purpose throughout: it is true for NaN, which is the point.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod batch;
pub mod bytes;
pub mod choice;
pub mod cli;
pub mod colour;
pub mod cpu;
pub mod engine;
pub mod formats;
pub mod geometry;
pub mod ibl_presets;
pub mod maths;
mod memory;
pub mod ops;
pub mod plotting;
pub mod report;
pub mod values;

#[cfg(test)]
mod test_skip;

pub use engine::graph::{Override, Pipeline};
pub use engine::op::{OpContext, OpError, OpSpec, OutputType, Outputs};
pub use engine::registry::Registry;
pub use engine::value::{Value, ValueType};
pub use ops::builtin_registry;
