//! What an operator is: an [`OpSpec`] (name, version, typed fields, output ports, evaluation).
//!
//! An operator file declares its parameters as a struct with `params!`, and a `spec()` function
//! that builds the spec; its domain's `mod.rs` registers it with one line. The smallest one:
//!
//! ```ignore
//! params! { pub struct ExposureParams {
//!     /// exposure change in stops (+1 doubles)
//!     #[range(-126.0, 126.0)]
//!     pub stops: f64,
//! } }
//!
//! pub fn spec() -> OpSpec {
//!     OpSpec::new("Exposure", "image", 1, "Scale an image by 2^stops")
//!         .input("image", &[IMAGE, SCALAR_FIELD], "the image to scale")
//!         .output("image", OutputType::SameAsInput("image"), "the scaled image")
//!         .code_hash(crate::op_code_hash!())
//!         .eval(|ctx, p: ExposureParams| { ... })
//! }
//! ```
//!
//! The engine validates a node's fields against the spec before anything runs, so `eval`
//! receives typed parameters and inputs of the declared types; it never checks them again.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::engine::params::{Arity, FieldKind, FieldSpec, ParamSet, Params};

/// Checks that two inputs' sizes, when both are known before running, are equal; the message
/// names both.
pub fn check_same_size(ctx: &CheckContext, a: &'static str, b: &'static str) -> Result<(), CheckProblem> {
    match (ctx.input_size(a), ctx.input_size(b)) {
        (Some(sa), Some(sb)) if sa != sb => Err(CheckProblem::at(
            b,
            format!("{b:?} is {}x{} but {a:?} is {}x{}: they must be the same size", sb.0, sb.1, sa.0, sa.1),
        )),
        _ => Ok(()),
    }
}
pub use crate::engine::cache::Persist;
use crate::engine::value::{Value, ValueData, ValueType};

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

/// How an output port's type is known before anything runs.
#[derive(Clone, Copy)]
pub enum OutputType {
    Fixed(ValueType),
    /// The type of the value wired into this input field (the first, for a list).
    SameAsInput(&'static str),
    /// A function of the node's parameters and input types.
    Computed(fn(&CheckContext) -> Result<ValueType, String>),
}

impl OutputType {
    pub fn describe(&self) -> String {
        match self {
            OutputType::Fixed(t) => t.to_string(),
            OutputType::SameAsInput(f) => format!("same type as `{f}`"),
            OutputType::Computed(_) => "depends on inputs and parameters".into(),
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

/// An operator's failure. The engine adds the node's name when it reports it.
#[derive(Debug, thiserror::Error)]
pub enum OpError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file that is not what it claims to be (bad magic, truncated, hostile header).
    #[error("{}: {message}", path.display())]
    Format { path: PathBuf, message: String },
    /// Input data the operator cannot process (NaN texels, empty images, ...).
    #[error("{0}")]
    Invalid(String),
}

/// What an operator's `eval` sees: its inputs' values, and where paths resolve.
pub struct OpContext<'a> {
    /// The node's name in the pipeline file.
    pub node: &'a str,
    /// The validated parameters (the typed struct is built from these).
    pub params: &'a Params,
    /// Input field -> values wired into it, in order (one for `One`, zero or one for
    /// `Optional`, any number for `List`).
    pub inputs: Vec<(&'static str, Vec<Value>)>,
    /// The pipeline file's folder: relative paths are resolved against it.
    pub base_dir: &'a Path,
    /// What `OpSpec::content_key` returned when the key was made (a loader checks that the
    /// file it decodes is still the one its key names).
    pub content_key: Option<&'a [u8]>,
    /// The names of this node's open ports that consumers use (see [`OpenPorts`]).
    pub wanted_ports: &'a [String],
}

impl<'a> OpContext<'a> {
    fn values(&self, field: &str) -> &[Value] {
        self.inputs
            .iter()
            .find(|(f, _)| *f == field)
            .map(|(_, v)| v.as_slice())
            .unwrap_or_else(|| panic!("input {field:?} is not declared"))
    }
    fn values_mut(&mut self, field: &str) -> &mut Vec<Value> {
        self.inputs
            .iter_mut()
            .find(|(f, _)| *f == field)
            .map(|(_, v)| v)
            .unwrap_or_else(|| panic!("input {field:?} is not declared"))
    }

    /// The value of a single input.
    pub fn input(&self, field: &str) -> &Value {
        self.values(field).first().unwrap_or_else(|| panic!("input {field:?} missing after validation"))
    }

    /// The value of an optional input, if it is wired.
    pub fn optional(&self, field: &str) -> Option<&Value> {
        self.values(field).first()
    }

    /// The values of a list input, in order.
    pub fn list(&self, field: &str) -> &[Value] {
        self.values(field)
    }

    /// A single input as `T` (its type was checked by validation).
    pub fn get<T: ValueData>(&self, field: &str) -> &T {
        let v = self.input(field);
        v.get::<T>().unwrap_or_else(|| panic!("input {field:?} is a {}, not the type eval expects", v.value_type()))
    }

    /// An optional input as `T`.
    pub fn get_optional<T: ValueData>(&self, field: &str) -> Option<&T> {
        self.optional(field).map(|v| {
            v.get::<T>().unwrap_or_else(|| panic!("input {field:?} is a {}, not the type eval expects", v.value_type()))
        })
    }

    /// A single input as a shared `Arc<T>`.
    pub fn arc<T: ValueData>(&self, field: &str) -> Arc<T> {
        let v = self.input(field);
        v.arc::<T>().unwrap_or_else(|| panic!("input {field:?} is a {}, not the type eval expects", v.value_type()))
    }

    /// A single input by value: its buffer is moved out when this node is its last consumer
    /// (nothing else holds it), and copied otherwise. The input is gone from the context after.
    pub fn take<T: ValueData + Clone>(&mut self, field: &str) -> T {
        let values = self.values_mut(field);
        assert!(!values.is_empty(), "input {field:?} missing after validation");
        let v = values.remove(0);
        let ty = v.value_type();
        v.take::<T>().unwrap_or_else(|| panic!("input {field:?} is a {ty}, not the type eval expects"))
    }

    /// A path parameter resolved against the pipeline file's folder (`builtin:` names unchanged).
    pub fn path(&self, path: &str) -> PathBuf {
        resolve_path(self.base_dir, path)
    }
}

/// Resolves `path` against `base_dir` unless it is absolute or a `builtin:` name.
pub fn resolve_path(base_dir: &Path, path: &str) -> PathBuf {
    let p = Path::new(path);
    if path.starts_with("builtin:") || p.is_absolute() {
        p.to_path_buf()
    } else {
        base_dir.join(p)
    }
}

/// A pixel size (width, height) known before running, when it is.
pub type Size = Option<(u64, u64)>;

/// What `OpSpec::check`, computed output types and sizes see: a node's parameters, and the
/// types and (when known before running) pixel sizes of its inputs.
pub struct CheckContext<'a> {
    pub params: &'a Params,
    /// Input field -> types of the values wired in, in order (empty when not wired).
    pub input_types: &'a BTreeMap<&'static str, Vec<ValueType>>,
    /// Input field -> sizes of the values wired in, in order (`None`: not known before running).
    pub input_sizes: &'a BTreeMap<&'static str, Vec<Size>>,
    /// The pipeline file's folder (a loader reads its file's header from there).
    pub base_dir: &'a Path,
}

impl CheckContext<'_> {
    /// The type of a single input (None when not wired).
    pub fn input_type(&self, field: &str) -> Option<ValueType> {
        self.input_types.get(field).and_then(|v| v.first().copied())
    }
    /// The size of a single input, when known before running.
    pub fn input_size(&self, field: &str) -> Size {
        self.input_sizes.get(field).and_then(|v| v.first().copied().flatten())
    }
    /// The typed parameters.
    pub fn typed<P: ParamSet>(&self) -> P {
        P::from_params(self.params)
    }
}

/// A problem found by `OpSpec::check`, optionally tied to one field (for its position).
#[derive(Debug, Clone)]
pub struct CheckProblem {
    pub field: Option<&'static str>,
    pub message: String,
}

impl CheckProblem {
    pub fn at(field: &'static str, message: impl Into<String>) -> Self {
        CheckProblem { field: Some(field), message: message.into() }
    }
}

/// Returns a loader's content bytes for its key (e.g. the hash of the file it will read).
pub type ContentKeyFn = fn(&Params, &Path) -> Result<Vec<u8>, OpError>;
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
        }
    }

    /// How its large results weigh in the cache's store decision (default `Measured`; see
    /// `engine::cache::policy`).
    pub fn persist(mut self, persist: Persist) -> Self {
        self.persist = persist;
        self
    }

    /// Adds a required single input.
    pub fn input(self, name: &'static str, types: &[ValueType], doc: &str) -> Self {
        self.input_with(name, types, Arity::One, doc)
    }

    /// Adds an optional input (absent: not wired).
    pub fn optional_input(self, name: &'static str, types: &[ValueType], doc: &str) -> Self {
        self.input_with(name, types, Arity::Optional, doc)
    }

    /// Adds a list input of `min..=max` nodes.
    pub fn list_input(self, name: &'static str, types: &[ValueType], min: usize, max: usize, doc: &str) -> Self {
        self.input_with(name, types, Arity::List { min, max }, doc)
    }

    fn input_with(mut self, name: &'static str, types: &[ValueType], arity: Arity, doc: &str) -> Self {
        self.fields.push(FieldSpec {
            name,
            kind: FieldKind::Input { types: types.to_vec(), arity },
            default: None,
            doc: doc.to_string(),
        });
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

    /// The evaluation, with typed parameters: `P`'s fields are appended to the spec's fields
    /// (after the inputs declared so far), so the struct is the one declaration of them.
    pub fn eval<P, R>(mut self, f: fn(&mut OpContext, P) -> Result<R, OpError>) -> Self
    where
        P: ParamSet + 'static,
        R: Into<Outputs> + 'static,
    {
        self.fields.extend(P::fields());
        self.eval = Arc::new(move |ctx: &mut OpContext| {
            let p = P::from_params(ctx.params);
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
        self.eval = f;
        self
    }

    /// Cross-field validation with typed parameters.
    pub fn check<P: ParamSet + 'static>(mut self, f: fn(&CheckContext, P) -> Result<(), CheckProblem>) -> Self {
        self.check = Some(Arc::new(move |ctx: &CheckContext| f(ctx, P::from_params(ctx.params))));
        self
    }

    /// The default output's pixel size from typed parameters and input sizes.
    pub fn size<P: ParamSet + 'static>(mut self, f: fn(&CheckContext, P) -> Size) -> Self {
        self.size = Some(Arc::new(move |ctx: &CheckContext| f(ctx, P::from_params(ctx.params))));
        self
    }

    /// The default output has the pixel size of this input (the first, for a list).
    pub fn size_of_input(mut self, field: &'static str) -> Self {
        self.size = Some(Arc::new(move |ctx: &CheckContext| ctx.input_size(field)));
        self
    }

    /// The loader's content key (see the field).
    pub fn content_key(mut self, f: ContentKeyFn) -> Self {
        self.content_key = Some(f);
        self
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
    /// the table `build.rs` makes: `crate::op_code_hash!()`).
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

include!(concat!(env!("OUT_DIR"), "/op_sources.rs"));

/// The code hash of the built-in operator file at `file` (`file!()`, relative or absolute: the
/// table entry it ends with), zero for a file the table does not hold.
pub fn builtin_code_hash(file: &str) -> [u8; 32] {
    let file = file.replace('\\', "/");
    OP_SOURCES.iter().find(|(path, _)| file.ends_with(path)).map(|(_, h)| *h).unwrap_or([0; 32])
}

/// The code hash of the built-in operator file this macro is written in (see `OpSpec::code`).
#[doc(hidden)]
#[macro_export]
macro_rules! op_code_hash {
    () => {
        $crate::engine::op::builtin_code_hash(file!())
    };
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_operator_file_has_a_code_hash() {
        assert!(super::OP_SOURCES.len() > 20);
        let h = super::builtin_code_hash("/abs/prefix/src/ops/image/exposure.rs");
        assert_ne!(h, [0; 32]);
        assert_eq!(h, super::builtin_code_hash("src/ops/image/exposure.rs"));
        assert_ne!(h, super::builtin_code_hash("src/ops/image/luminance.rs"));
    }
}
