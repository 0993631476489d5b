//! [`Op`]: an operator declared as one typed item, its `params!` struct.
//!
//! `Op::new(name, version, doc, eval)` takes the evaluation first, so the struct `P` it receives
//! is known to every later builder call: `check`, `size`, `content_key` and the computed output
//! types take `P::Check` by type (a function written for another struct does not compile, where
//! [`OpSpec`]'s untyped methods skipped it silently). The category is the name of the module
//! that holds the struct's module (`ops::image::exposure` -> `image`), so the folder says it once;
//! the source file is recorded for the registry's code hash (see
//! [`Registry::with_source_hashes`](crate::engine::registry::Registry::with_source_hashes)).
//! Output ports are typed handles ([`Port`]), declared once as constants and used by the spec and
//! by `eval`'s [`Outputs::with`](crate::engine::op::Outputs).
//!
//! ```ignore
//! pub fn spec() -> OpSpec {
//!     Op::new("Exposure", 2, "Scale an image by 2^stops (alpha unchanged)", eval)
//!         .output_like("image", |p| p.image, "the scaled image")
//!         .size(|_, p| p.image.size)
//!         .check(check)
//!         .into()
//! }
//! ```

use std::marker::PhantomData;
use std::path::Path;

use crate::engine::context::{CheckContext, CheckProblem, OpContext, OpError, Size};
use crate::engine::fields::{Fields, Shape};
use crate::engine::op::{OpSpec, OutputType, Outputs, Persist};
use crate::engine::value::{ValueData, ValueType};

/// An output port's name, typed by the Rust type of the values it carries: declared once
/// (`const MASK: Port<Image> = Port::new("mask");`), then named by the spec and by `eval`.
pub struct Port<T> {
    pub name: &'static str,
    kind: PhantomData<fn() -> T>,
}

impl<T> Port<T> {
    pub const fn new(name: &'static str) -> Self {
        Port { name, kind: PhantomData }
    }
}

impl<T> From<Port<T>> for &'static str {
    fn from(port: Port<T>) -> &'static str {
        port.name
    }
}

impl<T> Clone for Port<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Port<T> {}

// Beside `Port`, not beside `Outputs::with` in `op.rs`: `op.rs` is below this file (this file
// imports it), and `Port` belongs to the typed item.
impl Outputs {
    /// Adds the value of `port`.
    pub fn port<T: ValueData>(self, port: Port<T>, data: T) -> Self {
        self.with(port.name, crate::engine::value::Value::new(data))
    }
}

/// An operator spec under construction whose fields are the `params!` struct `P`.
pub struct Op<P: Fields> {
    spec: OpSpec,
    kind: PhantomData<fn() -> P>,
}

/// The category of an operator whose `params!` struct is declared in module `module`
/// (`module_path!()`): the second-to-last segment (`hdrflow::ops::image::exposure` -> `image`), or
/// the crate's name for a struct at a crate's top level.
pub fn category_of(module: &'static str) -> &'static str {
    let mut segments = module.rsplit("::");
    let last = segments.next().unwrap_or(module);
    segments.next().unwrap_or(last)
}

impl<P: Fields + 'static> Op<P> {
    /// An operator named `name` (the name in pipeline files), at `version` (bump it when its
    /// output for the same fields may change), with a one-line `doc` for `hdrflow ops`, that
    /// evaluates with `eval`.
    pub fn new<R>(
        name: &'static str,
        version: u32,
        doc: &'static str,
        eval: fn(&mut OpContext, P) -> Result<R, OpError>,
    ) -> Self
    where
        R: Into<Outputs> + 'static,
    {
        let mut spec = OpSpec::new(name, category_of(P::MODULE), version, doc).eval(eval);
        spec.source_file = Some(P::SOURCE);
        Op { spec, kind: PhantomData }
    }

    /// Overrides the category taken from the module path.
    pub fn category(mut self, category: &'static str) -> Self {
        self.spec.category = category;
        self
    }

    /// How its large results weigh in the cache's store decision (see `engine::cache::policy`).
    pub fn persist(mut self, persist: Persist) -> Self {
        self.spec = self.spec.persist(persist);
        self
    }

    /// Adds an output port of a type known without the fields (the first added is the default).
    pub fn output(mut self, name: &'static str, ty: ValueType, doc: &'static str) -> Self {
        self.spec = self.spec.output(name, OutputType::Fixed(ty), doc);
        self
    }

    /// [`Op::output`] for a typed port.
    pub fn port<T>(self, port: Port<T>, ty: ValueType, doc: &'static str) -> Self {
        self.output(port.name, ty, doc)
    }

    /// Adds an output port of the type of one input: `.output_like("image", |p| p.image, "...")`.
    pub fn output_like(mut self, name: impl Into<&'static str>, f: fn(P::Check) -> Shape, doc: &'static str) -> Self {
        self.spec = self.spec.output_like::<P::Check>(name.into(), f, doc);
        self
    }

    /// Adds an output port whose type follows from the fields before running; `how` says what it
    /// depends on, for `hdrflow ops`.
    pub fn output_computed(
        mut self,
        name: impl Into<&'static str>,
        how: &'static str,
        f: fn(&CheckContext, P::Check) -> Result<ValueType, String>,
        doc: &'static str,
    ) -> Self {
        self.spec = self.spec.output_computed::<P::Check>(name.into(), how, f, doc);
        self
    }

    /// Accepts ports under any name, of type `ty`, resolved when the node runs.
    pub fn open_ports(mut self, ty: ValueType, doc: &'static str) -> Self {
        self.spec = self.spec.open_ports(ty, doc);
        self
    }

    /// Cross-field validation before anything runs.
    pub fn check(mut self, f: fn(&CheckContext, P::Check) -> Result<(), CheckProblem>) -> Self {
        self.spec = self.spec.check::<P::Check>(f);
        self
    }

    /// The default output's pixel size before running, when the fields tell it.
    pub fn size(mut self, f: fn(&CheckContext, P::Check) -> Size) -> Self {
        self.spec = self.spec.size::<P::Check>(f);
        self
    }

    /// A loader's content key (see [`OpSpec::content_key`]).
    pub fn content_key(mut self, f: fn(P::Check, &Path) -> Result<Vec<u8>, OpError>) -> Self {
        self.spec = self.spec.content_key::<P::Check>(f);
        self
    }

    /// The spec, finished.
    pub fn spec(self) -> OpSpec {
        self.spec
    }
}

impl<P: Fields + 'static> From<Op<P>> for OpSpec {
    fn from(op: Op<P>) -> OpSpec {
        op.spec
    }
}

#[cfg(test)]
mod tests {
    use super::category_of;

    #[test]
    fn the_category_is_the_folder_of_the_operator_file() {
        assert_eq!(category_of("hdrflow::ops::image::exposure"), "image");
        assert_eq!(category_of("my_ops::invert"), "my_ops");
        assert_eq!(category_of("my_ops"), "my_ops");
    }
}
