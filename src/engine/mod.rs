//! The engine: pipeline files, values, the operators' interface, registry, scheduler and cache.
//! The engine never names an operator nor a data type: operators reach it only through
//! `OpSpec` and the `Registry`, data types through `TypeSpec` and `ValueData`.

pub mod cache;
pub mod context;
pub mod error;
pub mod fields;
pub mod graph;
pub mod normalise;
pub mod op;
pub mod params;
pub mod registry;
pub mod save;
pub mod scheduler;
pub mod typed_op;
pub mod value;
