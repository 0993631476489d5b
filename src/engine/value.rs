//! Values that flow along the graph's edges, and their open set of types.
//!
//! A value is an immutable `Arc` of any Rust type that implements [`ValueData`]; its type is a
//! [`ValueType`], a pointer to a static [`TypeSpec`] declared by whoever owns the data type (the
//! built-in ones in `crate::values`, a user's in their own crate). The spec says how the type is
//! named in `hdrflow ops` and messages and how the cache encodes and decodes it, so adding a
//! value type touches no engine file: declare a `TypeSpec`, implement `ValueData`, and register
//! the type with `Registry::register_type`. How `Save` writes a type as a file is registered
//! apart, by whoever knows the format (`Registry::register_saver`, see [`super::save`]).
//!
//! The type of every value is known before anything runs (operators declare their output
//! types), so a pipeline that wires an image into a sample input fails validation, not
//! evaluation; the scheduler also checks every computed and loaded value against its declared
//! type.

use std::any::Any;
use std::fmt;
use std::sync::Arc;

/// Decodes a cache payload into a value of this type.
pub type DecodeFn = fn(&[u8]) -> Result<Value, String>;

/// The declaration of a value type.
pub struct TypeSpec {
    /// The name in `hdrflow ops`, messages and cache entries, e.g. `image`. Unique.
    pub name: &'static str,
    /// One line for `hdrflow ops`.
    pub doc: &'static str,
    /// Reads a cache payload written by `ValueData::encode`; checks every length before
    /// allocating (a corrupt entry is an error, never a panic or a huge allocation).
    pub decode: DecodeFn,
}

impl fmt::Debug for TypeSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "TypeSpec({})", self.name)
    }
}

/// A value type: a handle to its static declaration, compared by name.
#[derive(Clone, Copy)]
pub struct ValueType(pub &'static TypeSpec);

impl ValueType {
    pub fn name(self) -> &'static str {
        self.0.name
    }
    pub fn spec(self) -> &'static TypeSpec {
        self.0
    }
}

impl PartialEq for ValueType {
    fn eq(&self, other: &Self) -> bool {
        self.0.name == other.0.name
    }
}
impl Eq for ValueType {}
impl PartialOrd for ValueType {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for ValueType {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.name.cmp(other.0.name)
    }
}
impl std::hash::Hash for ValueType {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.name.hash(state)
    }
}
impl fmt::Debug for ValueType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0.name)
    }
}
impl fmt::Display for ValueType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0.name)
    }
}

/// What a Rust type needs to travel on the graph's edges.
pub trait ValueData: Any + Send + Sync + fmt::Debug {
    /// The value's type (it may depend on the content: a one-channel image is a scalar field).
    fn value_type(&self) -> ValueType;
    /// Approximate heap size in bytes (reports, memory accounting).
    fn approx_bytes(&self) -> usize;
    /// The cache payload, read back by the type's `TypeSpec::decode`.
    fn encode(&self, out: &mut Vec<u8>);
    /// The value in full as text, for small values worth printing after a run (metrics, a
    /// light); `None` for values too large to print (images).
    fn display(&self) -> Option<String> {
        None
    }
    /// One line describing the value (size, channels, count).
    fn summary(&self) -> String {
        format!("a {} of about {} bytes", self.value_type(), self.approx_bytes())
    }
}

/// What stands in a port its operator did not produce because nothing in the run reads it
/// ([`crate::engine::op::OpContext::wants`]): of the port's type, never handed to a consumer
/// and never stored in the cache (`Value::is_absent`).
#[derive(Debug)]
pub(crate) struct Absent(pub ValueType);

impl ValueData for Absent {
    fn value_type(&self) -> ValueType {
        self.0
    }
    fn approx_bytes(&self) -> usize {
        0
    }
    fn encode(&self, _: &mut Vec<u8>) {}
    fn summary(&self) -> String {
        format!("a {} not computed (nothing read it)", self.0)
    }
}

/// A value on an edge of the graph: shared, immutable, of an open set of types.
#[derive(Clone)]
pub struct Value {
    ty: ValueType,
    data: Arc<dyn Any + Send + Sync>,
    /// The same allocation seen through the `ValueData` trait.
    view: Arc<dyn ValueData>,
}

impl fmt::Debug for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Value<{}>({:?})", self.ty, self.view)
    }
}

impl Value {
    /// Wraps a value.
    pub fn new<T: ValueData>(data: T) -> Value {
        Value::from_arc(Arc::new(data))
    }

    /// Wraps a shared value without copying it.
    pub fn from_arc<T: ValueData>(data: Arc<T>) -> Value {
        let ty = data.value_type();
        let view: Arc<dyn ValueData> = data.clone();
        Value { ty, data, view }
    }

    pub fn value_type(&self) -> ValueType {
        self.ty
    }

    /// The data as `T`, if it is one.
    pub fn get<T: ValueData>(&self) -> Option<&T> {
        self.data.downcast_ref::<T>()
    }

    /// The shared data as `Arc<T>`, if it is one.
    pub fn arc<T: ValueData>(&self) -> Option<Arc<T>> {
        self.data.clone().downcast::<T>().ok()
    }

    /// The data by value: moved out when this is the only reference (an operator that is the
    /// last consumer of its input reuses the buffer), cloned otherwise.
    pub fn take<T: ValueData + Clone>(self) -> Option<T> {
        let Value { data, view, .. } = self;
        drop(view);
        let arc = data.downcast::<T>().ok()?;
        Some(Arc::try_unwrap(arc).unwrap_or_else(|shared| (*shared).clone()))
    }

    pub fn approx_bytes(&self) -> usize {
        self.view.approx_bytes()
    }

    /// Whether this stands for a port that was not computed because nothing read it.
    pub fn is_absent(&self) -> bool {
        self.get::<Absent>().is_some()
    }

    /// See [`ValueData::display`].
    pub fn display(&self) -> Option<String> {
        self.view.display()
    }

    /// See [`ValueData::summary`].
    pub fn summary(&self) -> String {
        self.view.summary()
    }

    /// The cache payload of this value.
    pub fn encode(&self, out: &mut Vec<u8>) {
        self.view.encode(out)
    }

    /// Whether two values share one allocation.
    pub fn ptr_eq(&self, other: &Value) -> bool {
        Arc::ptr_eq(&self.data, &other.data)
    }
}

/// An encoded output file: its path relative to the output folder, and its bytes. The engine
/// writes it into the output folder (atomically, only when the bytes differ). A value saved as
/// several files (a mip chain, one file per level) carries the others in `more`, each with its
/// path relative to the output folder, written the same way.
#[derive(Clone, Debug, PartialEq)]
pub struct FileBlob {
    pub rel_path: String,
    pub bytes: Vec<u8>,
    pub more: Vec<(String, Vec<u8>)>,
}

impl FileBlob {
    /// One file.
    pub fn new(rel_path: String, bytes: Vec<u8>) -> Self {
        FileBlob { rel_path, bytes, more: Vec::new() }
    }
    /// The same files with their bytes dropped (their paths kept): what a run holds once it has
    /// written them.
    pub fn written(&self) -> FileBlob {
        FileBlob {
            rel_path: self.rel_path.clone(),
            bytes: Vec::new(),
            more: self.more.iter().map(|(p, _)| (p.clone(), Vec::new())).collect(),
        }
    }
    /// Every file: the first, then `more`.
    pub fn files(&self) -> impl Iterator<Item = (&str, &[u8])> {
        std::iter::once((self.rel_path.as_str(), self.bytes.as_slice()))
            .chain(self.more.iter().map(|(p, b)| (p.as_str(), b.as_slice())))
    }
}

/// The engine's own value type: a file for the output folder (what `Save` produces).
pub static FILE: TypeSpec = TypeSpec {
    name: "file",
    doc: "an encoded file, written into the output folder by the engine",
    decode: decode_file,
};

impl ValueData for FileBlob {
    fn value_type(&self) -> ValueType {
        ValueType(&FILE)
    }
    fn approx_bytes(&self) -> usize {
        self.files().map(|(p, b)| p.len() + b.len()).sum()
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = crate::bytes::Writer(out);
        w.str(&self.rel_path);
        w.bytes(&self.bytes);
        w.u64(self.more.len() as u64);
        for (p, b) in &self.more {
            w.str(p);
            w.bytes(b);
        }
    }
}

fn decode_file(bytes: &[u8]) -> Result<Value, String> {
    let mut r = crate::bytes::Reader::new(bytes);
    let rel_path = r.str()?;
    let data = r.bytes()?.to_vec();
    let n = r.usize()?;
    // Each further file takes at least two length words: a hostile count fails here.
    r.need(n.saturating_mul(16))?;
    let mut more = Vec::with_capacity(n);
    for _ in 0..n {
        let p = r.str()?;
        more.push((p, r.bytes()?.to_vec()));
    }
    r.finish()?;
    Ok(Value::new(FileBlob { rel_path, bytes: data, more }))
}
