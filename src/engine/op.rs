//! What an operator is: an [`OpSpec`] (name, version, typed fields, output ports, evaluation).
//!
//! An operator file declares its fields, inputs and parameters, as one struct with `params!`
//! (see `engine::fields`), and a `spec()` function that builds the spec; its domain's `mod.rs`
//! registers it with one line. The smallest one, `FlipVertical`, is quoted in the book
//! (`docs/src/internals/adding-an-operator.md`), where a test keeps the quote equal to the file.
//!
//! The engine validates a node's fields against the spec before anything runs, so `eval`
//! receives the struct with typed parameters and inputs of the declared types; it never checks
//! them again.

use std::any::TypeId;
use std::path::Path;
use std::sync::Arc;

pub use crate::engine::context::{resolve_path, CheckContext, CheckProblem, OpContext, OpError, Size};
use crate::engine::fields::{CheckFields, Fields, Shape};
use crate::engine::params::FieldSpec;

/// Checks that two inputs' sizes, when both are known before running, are equal; the message
/// names both fields, and the problem is placed at `b`'s.
pub fn check_same_size(a: Shape, b: Shape) -> Result<(), CheckProblem> {
    match (a.size, b.size) {
        (Some(sa), Some(sb)) if sa != sb => Err(CheckProblem::at(
            b.field,
            format!(
                "{:?} is {}x{} but {:?} is {}x{}: they must be the same size",
                b.field, sb.0, sb.1, a.field, sa.0, sa.1
            ),
        )),
        _ => Ok(()),
    }
}

/// [`check_same_size`], and the same value type (a one-channel scalar field against a colour
/// image is found before running, from the producers' declared outputs).
pub fn check_same_shape(a: Shape, b: Shape) -> Result<(), CheckProblem> {
    if a.ty != b.ty {
        return Err(CheckProblem::at(
            b.field,
            format!(
                "{:?} gives {} but {:?} gives {}: they must have the same channels (Luminance makes a scalar field of an image)",
                b.field, b.ty, a.field, a.ty
            ),
        ));
    }
    check_same_size(a, b)
}
pub use crate::engine::cache::Persist;
use crate::engine::value::{Value, ValueType};

/// The engine's image size limit, in pixels: the same 2^28 (268 M) the file readers enforce.
/// A node whose output would be larger is a pipeline error at validation.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Checks a `width x height` output against [`MAX_PIXELS`]; the message names the sizes.
pub fn check_pixels(width: u64, height: u64) -> Result<(), String> {
    match width.checked_mul(height) {
        Some(n) if n <= MAX_PIXELS => Ok(()),
        _ => Err(format!(
            "a {width} x {height} image exceeds the engine's limit of {MAX_PIXELS} pixels (2^28, e.g. 16384 x 16384)"
        )),
    }
}

/// A port type computed from the node's typed fields before running.
pub type ComputedTypeFn = Arc<dyn Fn(&CheckContext) -> Result<ValueType, String> + Send + Sync>;

/// How an output port's type is known before anything runs.
#[derive(Clone)]
pub enum OutputType {
    Fixed(ValueType),
    /// A function of the node's parameters and input shapes (see [`OpSpec::output_computed`]);
    /// the text says what it depends on, for `hdrflow ops`.
    Computed(&'static str, ComputedTypeFn),
}

impl OutputType {
    pub fn describe(&self) -> String {
        match self {
            OutputType::Fixed(t) => t.to_string(),
            OutputType::Computed(how, _) => how.to_string(),
        }
    }
}

/// One named output of an operator. The first declared port is the default: a field that
/// names the node without a port (`"env"`) takes it; `"node.port"` takes a named one.
#[derive(Clone)]
pub struct PortSpec {
    pub name: &'static str,
    pub ty: OutputType,
    pub doc: &'static str,
}

/// Ports an operator accepts under any name, resolved when it runs (e.g. `SplitChannels` has
/// one per channel of its input, whose names are known only once the image is read).
#[derive(Clone)]
pub struct OpenPorts {
    pub ty: ValueType,
    pub doc: &'static str,
}

/// An operator's results: one value per port it produced. A single value is the default port.
#[derive(Debug, Default)]
pub struct Outputs(pub Vec<(String, Value)>);

impl Outputs {
    pub fn new() -> Self {
        Outputs(Vec::new())
    }
    /// Adds the value of port `name`.
    pub fn with(mut self, name: impl Into<String>, value: Value) -> Self {
        self.0.push((name.into(), value));
        self
    }
}

impl From<Value> for Outputs {
    /// The default port's value.
    fn from(v: Value) -> Self {
        Outputs(vec![(String::new(), v)])
    }
}

/// Returns a loader's content bytes for its key (e.g. the hash of the file it will read), from
/// its typed fields before running (see [`OpSpec::content_key`]).
pub type ContentKeyFn = Arc<dyn Fn(&CheckContext) -> Result<Vec<u8>, OpError> + Send + Sync>;
/// Cross-field validation of one node before anything runs.
pub type CheckFn = Arc<dyn Fn(&CheckContext) -> Result<(), CheckProblem> + Send + Sync>;
/// The pixel size of an operator's default output, from its parameters and input sizes, when it
/// can be told before running.
pub type SizeFn = Arc<dyn Fn(&CheckContext) -> Size + Send + Sync>;
/// An operator's evaluation.
pub type EvalFn = Arc<dyn Fn(&mut OpContext) -> Result<Outputs, OpError> + Send + Sync>;

/// The description of an operator. Build one with [`OpSpec::new`] and its builder methods.
#[derive(Clone)]
pub struct OpSpec {
    /// The name used in pipeline files, e.g. `LoadHdr`.
    pub name: &'static str,
    /// Domain for `hdrflow ops`: io, image, sampling, shading, plotting, ...
    pub category: &'static str,
    /// Bump whenever the output for the same parameters and inputs may change: it is in the
    /// key (so is a hash of the operator's source, see [`OpSpec::code`]).
    pub version: u32,
    /// One line for `hdrflow ops`.
    pub doc: &'static str,
    /// Inputs and parameters, in declaration order.
    pub fields: Vec<FieldSpec>,
    /// Output ports; the first is the default.
    pub outputs: Vec<PortSpec>,
    /// Ports under any other name, resolved at run time.
    pub open_ports: Option<OpenPorts>,
    pub eval: EvalFn,
    /// Extra bytes for the cache key computed before evaluation, e.g. a loader's file content
    /// hash. When set, `Path` fields are left out of the key (keys never hold paths).
    pub content_key: Option<ContentKeyFn>,
    /// Cross-field validation run before anything is evaluated.
    pub check: Option<CheckFn>,
    /// The default output's pixel size, when known before running (validation checks that
    /// inputs which must agree in size do).
    pub size: Option<SizeFn>,
    /// BLAKE3 of the operator's source with comments and blank space removed (see `code`);
    /// zero when not given. It is in the cache key.
    pub code_hash: [u8; 32],
    /// Whether its large results are worth storing (see `engine::cache::policy`).
    pub persist: Persist,
    /// The file its `params!` struct is declared in, when built with [`Op`](crate::engine::typed_op::Op):
    /// the registry takes its code hash from it (see `Registry::hash_sources_with`).
    pub source_file: Option<&'static str>,
    /// The `Check` struct `eval` was given (`P::Check`) and the one each typed closure
    /// (`check`, `size`, computed outputs, `content_key`) was given, so that
    /// `Registry::register` refuses a spec whose closures read another struct than `eval`'s:
    /// `from_check` would find none of its fields and the closure would silently never run.
    params_structs: ParamsStructs,
}

/// The params structs an [`OpSpec`]'s builder was given, by type (see `OpSpec::params_mismatch`).
#[derive(Clone, Default)]
struct ParamsStructs {
    eval: Option<(TypeId, &'static str)>,
    closures: Vec<(&'static str, TypeId, &'static str)>,
}

/// A typed closure of an [`OpSpec`] given another params struct than its `eval`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParamsMismatch {
    /// The builder method, e.g. `check`.
    pub method: &'static str,
    /// The struct that method's closure reads.
    pub found: &'static str,
    /// `eval`'s struct, in its check stage.
    pub expected: &'static str,
}

impl std::fmt::Debug for OpSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpSpec").field("name", &self.name).field("version", &self.version).finish()
    }
}

impl OpSpec {
    /// A spec with no fields, no outputs and an evaluation that fails; add them with the
    /// builder methods.
    pub fn new(name: &'static str, category: &'static str, version: u32, doc: &'static str) -> Self {
        OpSpec {
            name,
            category,
            version,
            doc,
            fields: Vec::new(),
            outputs: Vec::new(),
            open_ports: None,
            eval: Arc::new(move |_| Err(OpError::Invalid(format!("{name} has no evaluation")))),
            content_key: None,
            check: None,
            size: None,
            code_hash: [0; 32],
            persist: Persist::Measured,
            source_file: None,
            params_structs: ParamsStructs::default(),
        }
    }

    /// How its large results weigh in the cache's store decision (default `Measured`; see
    /// `engine::cache::policy`).
    pub fn persist(mut self, persist: Persist) -> Self {
        self.persist = persist;
        self
    }

    /// Adds an output port (the first added is the default).
    pub fn output(mut self, name: &'static str, ty: OutputType, doc: &'static str) -> Self {
        self.outputs.push(PortSpec { name, ty, doc });
        self
    }

    /// Accepts ports under any name, of type `ty`, resolved when the node runs.
    pub fn open_ports(mut self, ty: ValueType, doc: &'static str) -> Self {
        self.open_ports = Some(OpenPorts { ty, doc });
        self
    }

    /// The evaluation. `P` is the operator's `params!` struct: its fields (parameters and
    /// inputs) are the spec's fields, so the struct is their one declaration, and `f`
    /// receives it with every input already of its declared type.
    pub fn eval<P, R>(mut self, f: fn(&mut OpContext, P) -> Result<R, OpError>) -> Self
    where
        P: Fields + 'static,
        R: Into<Outputs> + 'static,
    {
        self.fields.extend(P::fields());
        self.params_structs.eval = Some((TypeId::of::<P::Check>(), std::any::type_name::<P::Check>()));
        self.eval = Arc::new(move |ctx: &mut OpContext| {
            let mut inputs = std::mem::take(&mut ctx.inputs);
            let p = P::from_run(ctx.params, &mut inputs)?;
            f(ctx, p).map(Into::into)
        });
        self
    }

    /// Adds a field declared at run time, for an operator whose fields are not a Rust struct
    /// (the Python bindings' `hdrflow.operator` declares them from a dict). Its name must be
    /// `'static`; such a caller leaks it once per registration.
    pub fn field_spec(mut self, field: FieldSpec) -> Self {
        self.fields.push(field);
        self
    }

    /// The evaluation without typed parameters: `f` reads `ctx.params` (validated against the
    /// declared fields) and returns its outputs itself. For operators declared at run time
    /// (with [`OpSpec::field_spec`]); a Rust operator uses [`OpSpec::eval`].
    pub fn eval_raw(mut self, f: EvalFn) -> Self {
        self.params_structs.eval = None;
        self.eval = f;
        self
    }

    /// Cross-field validation, from the typed fields before running (`P<Check>`: inputs are
    /// their [`Shape`](crate::engine::fields::Shape)s).
    pub fn check<C: CheckFields + 'static>(mut self, f: fn(&CheckContext, C) -> Result<(), CheckProblem>) -> Self {
        self.record_params::<C>("check");
        self.check = Some(Arc::new(move |ctx: &CheckContext| C::from_check(ctx).map_or(Ok(()), |p| f(ctx, p))));
        self
    }

    /// The default output's pixel size, from the typed fields before running (e.g.
    /// `|_, p: ExposureParams<Check>| p.image.size`).
    pub fn size<C: CheckFields + 'static>(mut self, f: fn(&CheckContext, C) -> Size) -> Self {
        self.record_params::<C>("size");
        self.size = Some(Arc::new(move |ctx: &CheckContext| C::from_check(ctx).and_then(|p| f(ctx, p))));
        self
    }

    /// Adds an output port whose type follows from the typed fields before running (e.g. the
    /// type of an input: `|_, p: ExposureParams<Check>| Ok(p.image.ty)`); `how` says what it
    /// depends on, for `hdrflow ops`.
    pub fn output_computed<C: CheckFields + 'static>(
        self,
        name: &'static str,
        how: &'static str,
        f: fn(&CheckContext, C) -> Result<ValueType, String>,
        doc: &'static str,
    ) -> Self {
        self.typed_output(name, how, f, doc)
    }

    /// Adds an output port of the type of one input: `.output_like("image", |p:
    /// ExposureParams<Check>| p.image, "the scaled image")`.
    pub fn output_like<C: CheckFields + 'static>(
        self,
        name: &'static str,
        f: fn(C) -> Shape,
        doc: &'static str,
    ) -> Self {
        self.typed_output(name, "the input's type", move |_, p: C| Ok(f(p).ty), doc)
    }

    fn typed_output<C: CheckFields + 'static>(
        mut self,
        name: &'static str,
        how: &'static str,
        f: impl Fn(&CheckContext, C) -> Result<ValueType, String> + Send + Sync + 'static,
        doc: &'static str,
    ) -> Self {
        self.record_params::<C>("output");
        let ty = OutputType::Computed(
            how,
            Arc::new(move |ctx: &CheckContext| match C::from_check(ctx) {
                Some(p) => f(ctx, p),
                None => Err(format!("output {name:?}: its type depends on an input that is not wired")),
            }),
        );
        self.output(name, ty, doc)
    }

    /// The loader's content key (see the field), from its typed fields.
    pub fn content_key<C: CheckFields + 'static>(mut self, f: fn(C, &Path) -> Result<Vec<u8>, OpError>) -> Self {
        self.record_params::<C>("content_key");
        self.content_key = Some(Arc::new(move |ctx: &CheckContext| match C::from_check(ctx) {
            Some(p) => f(p, ctx.base_dir),
            None => Err(OpError::Invalid("the content key depends on an input that is not wired".into())),
        }));
        self
    }

    fn record_params<C: 'static>(&mut self, method: &'static str) {
        self.params_structs.closures.push((method, TypeId::of::<C>(), std::any::type_name::<C>()));
    }

    /// The first typed closure given another params struct than `eval`'s (`None` when they all
    /// read `eval`'s, or when `eval` is untyped: [`OpSpec::eval_raw`]).
    pub fn params_mismatch(&self) -> Option<ParamsMismatch> {
        let (expected_id, expected) = self.params_structs.eval?;
        self.params_structs
            .closures
            .iter()
            .find(|(_, id, _)| *id != expected_id)
            .map(|&(method, _, found)| ParamsMismatch { method, found, expected })
    }

    /// The operator's source text (from its own file: `include_str!("my_op.rs")`, a path
    /// relative to that file): its hash, with comments and blank space removed, goes into every
    /// cache key of this operator, so a code change that may alter results never serves a stale
    /// entry even if nobody bumped the version.
    pub fn code(mut self, source: &str) -> Self {
        self.code_hash = *blake3::hash(normalise_source(source).as_bytes()).as_bytes();
        self
    }

    /// The hash `code` would compute, given directly (the built-in operators take theirs from
    /// the table of their files' hashes that `build.rs` makes, through
    /// `Registry::hash_sources_with`).
    pub fn code_hash(mut self, hash: [u8; 32]) -> Self {
        self.code_hash = hash;
        self
    }

    pub fn field(&self, name: &str) -> Option<&FieldSpec> {
        self.fields.iter().find(|f| f.name == name)
    }

    pub fn input_fields(&self) -> impl Iterator<Item = &FieldSpec> {
        self.fields.iter().filter(|f| f.is_input())
    }

    pub fn port(&self, name: &str) -> Option<&PortSpec> {
        self.outputs.iter().find(|p| p.name == name)
    }
}

pub use crate::engine::normalise::normalise_source;
