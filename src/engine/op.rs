//! What an operator is: a static `OpSpec` (name, version, typed fields with defaults and docs,
//! output type) and an evaluation function.
//!
//! An operator file declares one `pub static SPEC: OpSpec` and its `eval` function; its domain's
//! `mod.rs` registers it with one line. The engine validates a node's fields against `fields`
//! before anything runs, so `eval` may read its parameters with the typed getters of
//! `OpContext` without checking them again (a wrong type there is a broken invariant).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::data::{Curves, Distribution2D, Image, Metrics, SampleSet};
use crate::engine::value::{Value, ValueType};

/// The type and accepted range of one field.
#[derive(Clone, Copy, Debug)]
pub enum FieldKind {
    /// The name of another node, whose output must have one of these types.
    Input(&'static [ValueType]),
    /// A number (integer literals are accepted), inclusive range.
    Float {
        min: f64,
        max: f64,
    },
    /// An integer, inclusive range.
    Int {
        min: i64,
        max: i64,
    },
    Bool,
    /// Free text.
    Text,
    /// A file path or `builtin:NAME`. A loader's path is not part of its cache key: its content is.
    Path,
    /// One of these bare identifiers, e.g. `Rec709`.
    Choice(&'static [&'static str]),
    /// A tuple of N numbers, each in the inclusive range, e.g. `(0.0, 1.0, 0.0)`.
    Tuple {
        len: usize,
        min: f64,
        max: f64,
    },
}

impl FieldKind {
    /// How the kind reads in `hdrflow ops` and in error messages.
    pub fn describe(&self) -> String {
        match self {
            FieldKind::Input(types) => {
                let names: Vec<&str> = types.iter().map(|t| t.name()).collect();
                format!("input<{}>", names.join(" | "))
            }
            FieldKind::Float { min, max } => format!("float in [{}, {}]", fmt_bound(*min), fmt_bound(*max)),
            FieldKind::Int { min, max } => format!("integer in [{min}, {max}]"),
            FieldKind::Bool => "bool".into(),
            FieldKind::Text => "string".into(),
            FieldKind::Path => "path".into(),
            FieldKind::Choice(options) => options.join(" | "),
            FieldKind::Tuple { len, .. } => format!("({})", vec!["float"; *len].join(", ")),
        }
    }
}

fn fmt_bound(v: f64) -> String {
    if v == f64::INFINITY {
        "inf".into()
    } else if v == f64::NEG_INFINITY {
        "-inf".into()
    } else {
        format!("{v}")
    }
}

/// A field's default; `Required` means the field must be given.
#[derive(Clone, Copy, Debug)]
pub enum Default {
    Required,
    Float(f64),
    Int(i64),
    Bool(bool),
    Text(&'static str),
    Choice(&'static str),
    Tuple(&'static [f64]),
}

/// One field of an operator.
#[derive(Clone, Copy, Debug)]
pub struct FieldSpec {
    pub name: &'static str,
    pub kind: FieldKind,
    pub default: Default,
    pub doc: &'static str,
}

impl FieldSpec {
    pub const fn input(name: &'static str, types: &'static [ValueType], doc: &'static str) -> Self {
        FieldSpec { name, kind: FieldKind::Input(types), default: Default::Required, doc }
    }
    pub fn is_input(&self) -> bool {
        matches!(self.kind, FieldKind::Input(_))
    }
}

/// How an operator's output type is known before it runs.
#[derive(Clone, Copy, Debug)]
pub enum OutputType {
    Fixed(ValueType),
    /// The same type as the value wired into this input field.
    SameAsInput(&'static str),
}

/// A validated parameter value (inputs are not parameters: they are edges).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Text(String),
    Choice(String),
    Tuple(Vec<f64>),
}

/// A node's parameters after validation: every non-input field, given or defaulted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params {
    pub values: BTreeMap<String, ParamValue>,
}

impl Params {
    fn get(&self, name: &str) -> &ParamValue {
        self.values.get(name).unwrap_or_else(|| panic!("parameter {name:?} missing after validation"))
    }
    pub fn f64(&self, name: &str) -> f64 {
        match self.get(name) {
            ParamValue::Float(v) => *v,
            ParamValue::Int(v) => *v as f64,
            other => panic!("parameter {name:?} is not a number: {other:?}"),
        }
    }
    pub fn int(&self, name: &str) -> i64 {
        match self.get(name) {
            ParamValue::Int(v) => *v,
            other => panic!("parameter {name:?} is not an integer: {other:?}"),
        }
    }
    /// An integer field whose declared range is non-negative.
    pub fn usize(&self, name: &str) -> usize {
        self.int(name).max(0) as usize
    }
    pub fn bool(&self, name: &str) -> bool {
        match self.get(name) {
            ParamValue::Bool(v) => *v,
            other => panic!("parameter {name:?} is not a bool: {other:?}"),
        }
    }
    /// A `Text`, `Path` or `Choice` field.
    pub fn text(&self, name: &str) -> &str {
        match self.get(name) {
            ParamValue::Text(v) | ParamValue::Choice(v) => v,
            other => panic!("parameter {name:?} is not text: {other:?}"),
        }
    }
    pub fn tuple(&self, name: &str) -> &[f64] {
        match self.get(name) {
            ParamValue::Tuple(v) => v,
            other => panic!("parameter {name:?} is not a tuple: {other:?}"),
        }
    }
    pub fn vec2(&self, name: &str) -> [f64; 2] {
        let t = self.tuple(name);
        [t[0], t[1]]
    }
    pub fn vec3(&self, name: &str) -> [f64; 3] {
        let t = self.tuple(name);
        [t[0], t[1], t[2]]
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

/// What an operator's `eval` sees: its parameters, its inputs' values, and where paths resolve.
pub struct OpContext<'a> {
    /// The node's name in the pipeline file.
    pub node: &'a str,
    pub params: &'a Params,
    /// Input field name -> value of the node wired into it.
    pub inputs: &'a BTreeMap<&'static str, Value>,
    /// The pipeline file's folder: relative paths are resolved against it.
    pub base_dir: &'a Path,
    /// What `OpSpec::content_key` returned when the key was made (a loader checks that the
    /// file it decodes is still the one its key names).
    pub content_key: Option<&'a [u8]>,
}

impl<'a> OpContext<'a> {
    pub fn input(&self, field: &str) -> &Value {
        self.inputs.get(field).unwrap_or_else(|| panic!("input {field:?} missing after validation"))
    }
    /// An `Image` or `ScalarField` input.
    pub fn image(&self, field: &str) -> &Arc<Image> {
        self.input(field).as_image().expect("input type checked by validation")
    }
    pub fn distribution(&self, field: &str) -> &Arc<Distribution2D> {
        self.input(field).as_distribution().expect("input type checked by validation")
    }
    pub fn samples(&self, field: &str) -> &Arc<SampleSet> {
        self.input(field).as_samples().expect("input type checked by validation")
    }
    pub fn curves(&self, field: &str) -> &Arc<Curves> {
        self.input(field).as_curves().expect("input type checked by validation")
    }
    pub fn metrics(&self, field: &str) -> &Arc<Metrics> {
        self.input(field).as_metrics().expect("input type checked by validation")
    }
    /// A path field resolved against the pipeline file's folder (`builtin:` names unchanged).
    pub fn path(&self, field: &str) -> PathBuf {
        resolve_path(self.base_dir, self.params.text(field))
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

/// What `OpSpec::check` sees: a node's parameters and the types of its inputs.
pub struct CheckContext<'a> {
    pub params: &'a Params,
    pub input_types: &'a BTreeMap<&'static str, ValueType>,
}

/// A problem found by `OpSpec::check`, optionally tied to one field (for its position).
#[derive(Debug, Clone)]
pub struct CheckProblem {
    pub field: Option<&'static str>,
    pub message: String,
}

/// Returns a loader's content bytes for its key (e.g. the hash of the file it will read).
pub type ContentKeyFn = fn(&Params, &Path) -> Result<Vec<u8>, OpError>;

/// Cross-field validation of one node before anything runs.
pub type CheckFn = fn(&CheckContext) -> Result<(), CheckProblem>;

/// The static description of an operator.
pub struct OpSpec {
    /// The name used in pipeline files, e.g. `LoadHdr`.
    pub name: &'static str,
    /// Domain for `hdrflow ops`: io, image, sampling, shading, plotting, ...
    pub category: &'static str,
    /// Bump whenever the output for the same parameters and inputs may change: it is in the key.
    pub version: u32,
    /// One line for `hdrflow ops`.
    pub doc: &'static str,
    pub fields: &'static [FieldSpec],
    pub output: OutputType,
    pub eval: fn(&OpContext) -> Result<Value, OpError>,
    /// Extra bytes for the cache key computed before evaluation, e.g. a loader's file content
    /// hash. When set, `Path` fields are left out of the key (keys never hold paths).
    pub content_key: Option<ContentKeyFn>,
    /// Cross-field validation run before anything is evaluated (e.g. a file extension that
    /// must suit the input's type).
    pub check: Option<CheckFn>,
}

impl OpSpec {
    pub fn field(&self, name: &str) -> Option<&FieldSpec> {
        self.fields.iter().find(|f| f.name == name)
    }
    pub fn input_fields(&self) -> impl Iterator<Item = &FieldSpec> {
        self.fields.iter().filter(|f| f.is_input())
    }
}

impl std::fmt::Debug for OpSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpSpec").field("name", &self.name).field("version", &self.version).finish()
    }
}
