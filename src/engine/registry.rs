//! The operator registry: name -> spec. Built-in operators register in `crate::ops::register_all`;
//! a library user adds their own with `Registry::register` (see `examples/custom_operator.rs`).

use std::collections::BTreeMap;

use crate::engine::op::OpSpec;

#[derive(Default, Clone)]
pub struct Registry {
    ops: BTreeMap<&'static str, &'static OpSpec>,
}

impl Registry {
    /// An empty registry.
    pub fn empty() -> Self {
        Registry::default()
    }

    /// Every built-in operator.
    pub fn with_builtins() -> Self {
        let mut r = Registry::empty();
        crate::ops::register_all(&mut r);
        r
    }

    /// Adds an operator. A second operator with the same name replaces the first.
    pub fn register(&mut self, spec: &'static OpSpec) -> &mut Self {
        self.ops.insert(spec.name, spec);
        self
    }

    pub fn get(&self, name: &str) -> Option<&'static OpSpec> {
        self.ops.get(name).copied()
    }

    /// Operators sorted by category, then name.
    pub fn all(&self) -> Vec<&'static OpSpec> {
        let mut v: Vec<_> = self.ops.values().copied().collect();
        v.sort_by_key(|s| (s.category, s.name));
        v
    }

    pub fn names(&self) -> Vec<&'static str> {
        self.ops.keys().copied().collect()
    }
}
