//! The registry: operator name -> spec, and value-type name -> type spec.
//!
//! The engine starts empty and knows no operator: the built-ins are registered by
//! `hdrflow::ops::builtin_registry()`, outside the engine. A library user adds their own
//! operators and value types to that registry (see `examples/custom_operator.rs`) and hands it to
//! `hdrflow::cli::main_with` to get the whole command line over it.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::engine::op::OpSpec;
use crate::engine::value::{TypeSpec, ValueType, FILE};

#[derive(Clone)]
pub struct Registry {
    ops: BTreeMap<&'static str, Arc<OpSpec>>,
    types: BTreeMap<&'static str, ValueType>,
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry").field("ops", &self.names()).field("types", &self.types.keys()).finish()
    }
}

impl Default for Registry {
    fn default() -> Self {
        Registry::empty()
    }
}

impl Registry {
    /// A registry with no operator, and only the engine's own `file` type.
    pub fn empty() -> Self {
        let mut r = Registry { ops: BTreeMap::new(), types: BTreeMap::new() };
        r.register_type(&FILE);
        r
    }

    /// Adds an operator. A second operator with the same name replaces the first.
    pub fn register(&mut self, spec: OpSpec) -> &mut Self {
        self.ops.insert(spec.name, Arc::new(spec));
        self
    }

    /// Adds a value type (its cache codec and how `Save` writes it). Operators' input and output
    /// types must be registered for their values to be cached.
    pub fn register_type(&mut self, spec: &'static TypeSpec) -> &mut Self {
        self.types.insert(spec.name, ValueType(spec));
        self
    }

    pub fn get(&self, name: &str) -> Option<&Arc<OpSpec>> {
        self.ops.get(name)
    }

    /// A value type by name (cache entries name their values' types).
    pub fn value_type(&self, name: &str) -> Option<ValueType> {
        self.types.get(name).copied()
    }

    pub fn value_types(&self) -> Vec<ValueType> {
        self.types.values().copied().collect()
    }

    /// Operators sorted by category, then name.
    pub fn all(&self) -> Vec<&Arc<OpSpec>> {
        let mut v: Vec<_> = self.ops.values().collect();
        v.sort_by_key(|s| (s.category, s.name));
        v
    }

    pub fn names(&self) -> Vec<&'static str> {
        self.ops.keys().copied().collect()
    }
}
