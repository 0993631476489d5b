//! The registry: operator name -> spec, value-type name -> type spec, and value-type name -> how
//! `Save` writes it (its saver, registered apart from the type: see `engine::save`).
//!
//! The engine starts empty and knows no operator: the built-ins are registered by
//! `hdrflow::ops::builtin_registry()`, outside the engine. A library user adds their own
//! operators and value types to that registry (see `examples/custom_operator.rs`) and hands it to
//! `hdrflow::cli::main_with` to get the whole command line over it.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::engine::op::{OpSpec, ParamsMismatch};
use crate::engine::save::{SaveFn, Saver, Savers};
use crate::engine::value::{TypeSpec, ValueType, FILE};

#[derive(Clone)]
pub struct Registry {
    ops: BTreeMap<&'static str, Arc<OpSpec>>,
    types: BTreeMap<&'static str, ValueType>,
    savers: Savers,
    /// The code hash of an operator's source file, for specs that name their file and give no
    /// hash of their own (see [`Registry::hash_sources_with`]).
    source_hash: Option<fn(&str) -> [u8; 32]>,
}

/// Why an operator could not be registered.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum RegistryError {
    #[error("an operator named {0:?} is already registered: operator names must be unique")]
    Duplicate(&'static str),
    /// A typed closure (`check`, `size`, a computed output, `content_key`) reads another params
    /// struct than `eval`: it would never run (see `OpSpec::params_mismatch`).
    #[error("operator {op:?}: its `{}` reads {} but its `eval` reads {}: give both the same params struct", .mismatch.method, .mismatch.found, .mismatch.expected)]
    ParamsMismatch { op: &'static str, mismatch: ParamsMismatch },
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
        let mut r =
            Registry { ops: BTreeMap::new(), types: BTreeMap::new(), savers: Savers::default(), source_hash: None };
        r.register_type(&FILE);
        r
    }

    /// Adds an operator; a second operator of the same name is an error (it would silently
    /// replace the first), and so is a typed closure reading another params struct than `eval`
    /// (it would silently never run). A spec that names its source file (`OpSpec::source_file`) and has no
    /// code hash gets the hash [`Registry::hash_sources_with`] gives for that file.
    pub fn register(&mut self, spec: impl Into<OpSpec>) -> Result<&mut Self, RegistryError> {
        let mut spec = spec.into();
        if self.ops.contains_key(spec.name) {
            return Err(RegistryError::Duplicate(spec.name));
        }
        if let Some(mismatch) = spec.params_mismatch() {
            return Err(RegistryError::ParamsMismatch { op: spec.name, mismatch });
        }
        if let (Some(file), Some(hash), true) = (spec.source_file, self.source_hash, spec.code_hash == [0; 32]) {
            spec.code_hash = hash(file);
        }
        self.ops.insert(spec.name, Arc::new(spec));
        Ok(self)
    }

    /// Adds an operator in place of the one of the same name, if any (a Python operator declared
    /// again, e.g. when a notebook cell runs twice).
    pub fn replace(&mut self, spec: impl Into<OpSpec>) -> &mut Self {
        let spec = spec.into();
        self.ops.insert(spec.name, Arc::new(spec));
        self
    }

    /// How operators registered from now on that name their source file get their code hash
    /// (the built-ins: the table `build.rs` makes of their files' hashes). The engine knows no
    /// operator file; whoever registers them says how their files hash.
    pub fn hash_sources_with(&mut self, hash: fn(&str) -> [u8; 32]) -> &mut Self {
        self.source_hash = Some(hash);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registering_a_name_twice_is_an_error_and_replace_says_so() {
        let mut r = Registry::empty();
        r.register(OpSpec::new("A", "test", 1, "first")).unwrap();
        let e = r.register(OpSpec::new("A", "test", 2, "second")).unwrap_err();
        assert_eq!(e, RegistryError::Duplicate("A"));
        assert_eq!(r.get("A").unwrap().version, 1);
        r.replace(OpSpec::new("A", "test", 3, "third"));
        assert_eq!(r.get("A").unwrap().version, 3);
    }

    crate::params! {
        /// The struct `eval` reads.
        struct EvalParams {
            /// a number
            x: f64 = 1.0,
        }
    }

    crate::params! {
        /// Another struct, with another field.
        struct OtherParams {
            /// a number
            y: f64 = 2.0,
        }
    }

    fn eval(
        _: &mut crate::engine::op::OpContext,
        _: EvalParams,
    ) -> Result<crate::engine::value::Value, crate::engine::op::OpError> {
        Err(crate::engine::op::OpError::Invalid("not run".into()))
    }

    #[test]
    fn a_check_or_size_reading_another_params_struct_than_eval_is_an_error() {
        use crate::engine::fields::Check;
        let ok = OpSpec::new("Same", "test", 1, "same struct")
            .eval(eval)
            .check(|_, _: EvalParams<Check>| Ok(()))
            .size(|_, _: EvalParams<Check>| None);
        assert_eq!(ok.params_mismatch(), None);
        Registry::empty().register(ok).unwrap();

        let wrong_check =
            OpSpec::new("Check", "test", 1, "another struct").eval(eval).check(|_, _: OtherParams<Check>| Ok(()));
        let e = Registry::empty().register(wrong_check).unwrap_err();
        let RegistryError::ParamsMismatch { op: "Check", mismatch } = &e else { panic!("{e:?}") };
        assert_eq!(mismatch.method, "check");
        assert!(mismatch.found.contains("OtherParams") && mismatch.expected.contains("EvalParams"), "{mismatch:?}");
        assert!(e.to_string().contains("its `check` reads"), "{e}");

        // The closure may come before `eval` in the chain.
        let wrong_size =
            OpSpec::new("Size", "test", 1, "another struct").size(|_, _: OtherParams<Check>| None).eval(eval);
        let e = Registry::empty().register(wrong_size).unwrap_err();
        assert!(
            matches!(&e, RegistryError::ParamsMismatch { op: "Size", mismatch } if mismatch.method == "size"),
            "{e:?}"
        );
    }
}
