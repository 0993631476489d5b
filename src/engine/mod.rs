//! The engine: pipeline files, values, operators' interface, registry, scheduler and cache.
//! The engine never names an operator: operators reach it only through `OpSpec` and `Registry`.

pub mod cache;
pub mod error;
pub mod graph;
pub mod op;
pub mod registry;
pub mod scheduler;
pub mod value;
