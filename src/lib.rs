//! hdrflow: a node-graph engine for HDR image processing.
//!
//! - [`engine`]: pipeline files, validation, the parallel demand-driven scheduler, the cache.
//! - [`ops`]: the built-in operators, one file each, grouped by domain.
//! - [`data`], [`maths`], [`formats`], [`plotting`]: values, mathematics, file formats, plots.
//! - [`geometry`]: the lat-long convention, below all of them (it depends on nothing else).
//!
//! Running a pipeline from code:
//! ```no_run
//! use hdrflow::engine::{graph::Pipeline, registry::Registry, scheduler};
//! let registry = Registry::with_builtins();
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

pub mod bench;
pub mod data;
pub mod engine;
pub mod formats;
pub mod geometry;
pub mod maths;
pub mod ops;
pub mod plotting;

pub use engine::graph::{Override, Pipeline};
pub use engine::op::{OpContext, OpError, OpSpec};
pub use engine::registry::Registry;
pub use engine::value::{Value, ValueType};
