//! The registry: operator name -> spec, value-type name -> type spec, and value-type name -> how
//! `Save` writes it (its saver, registered apart from the type: see `engine::save`).
//!
//! The engine starts empty and knows no operator: the built-ins are registered by
//! `hdrflow::ops::builtin_registry()`, outside the engine. A library user adds their own
//! operators and value types to that registry (see `examples/custom_operator.rs`) and hands it to
//! `hdrflow::cli::main_with` to get the whole command line over it.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::engine::op::OpSpec;
use crate::engine::save::{SaveFn, Saver, Savers};
use crate::engine::value::{TypeSpec, ValueType, FILE};

#[derive(Clone)]
pub struct Registry {
    ops: BTreeMap<&'static str, Arc<OpSpec>>,
    types: BTreeMap<&'static str, ValueType>,
    savers: Savers,
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
        let mut r = Registry { ops: BTreeMap::new(), types: BTreeMap::new(), savers: Savers::default() };
        r.register_type(&FILE);
        r
    }

    /// Adds an operator. A second operator with the same name replaces the first.
    pub fn register(&mut self, spec: OpSpec) -> &mut Self {
        self.ops.insert(spec.name, Arc::new(spec));
        self
    }

    /// Adds a value type (its name and cache codec). Operators' input and output types must be
    /// registered for their values to be cached.
    pub fn register_type(&mut self, spec: &'static TypeSpec) -> &mut Self {
        self.types.insert(spec.name, ValueType(spec));
        self
    }

    /// Sets how `Save` writes values of type `spec`: the `extensions` it accepts (lower-case,
    /// without the dot) and the encoder `save`. A second saver of a type replaces the first; a
    /// type without one cannot be saved.
    pub fn register_saver(
        &mut self,
        spec: &'static TypeSpec,
        extensions: &'static [&'static str],
        save: SaveFn,
    ) -> &mut Self {
        self.savers.insert(spec, Saver { extensions, save });
        self
    }

    /// How `Save` writes values of type `ty`, if it can.
    pub fn saver(&self, ty: ValueType) -> Option<&Saver> {
        self.savers.get(ty)
    }

    /// Every saver (what operators' contexts carry).
    pub fn savers(&self) -> &Savers {
        &self.savers
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
