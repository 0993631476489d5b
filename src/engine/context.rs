//! What an operator sees of the engine: its context when it runs ([`OpContext`]), what its checks
//! see before anything runs ([`CheckContext`]), and its errors. Below `op` and `fields`, so that
//! both use it without depending on each other.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::engine::params::Params;
use crate::engine::save::Savers;
use crate::engine::value::{Value, ValueType};

/// A node's wired inputs as evaluation hands them to the struct: field -> values, in order.
pub type RunInputs = Vec<(&'static str, Vec<Value>)>;

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
    /// `Optional`, any number for `List`). A Rust operator receives them in its typed struct
    /// (they are moved there before its `eval` runs); an operator declared at run time
    /// ([`OpSpec::eval_raw`]) reads them here.
    pub inputs: RunInputs,
    /// The pipeline file's folder: relative paths are resolved against it.
    pub base_dir: &'a Path,
    /// What `OpSpec::content_key` returned when the key was made (a loader checks that the
    /// file it decodes is still the one its key names).
    pub content_key: Option<&'a [u8]>,
    /// The names of this node's open ports that consumers use (see [`OpenPorts`]).
    pub wanted_ports: &'a [String],
    /// The names of this node's ports that nothing in the run reads (no consumer that runs, not
    /// the caller): an operator may leave them out of its outputs ([`OpContext::wants`]).
    pub(crate) unread_ports: &'a [&'a str],
    /// How each value type is written as a file (the registry's savers: `Save` encodes with them).
    pub savers: &'a Savers,
    /// What [`OpContext::warn`] collected; the scheduler reports each, prefixed by the node.
    pub(crate) warnings: Vec<String>,
    /// Where [`OpContext::release`] hands a value back (the scheduler; None: it is just dropped).
    pub(crate) release_to: Option<&'a (dyn Fn(Value) + Sync)>,
    /// The operator's own data kept between runs ([`AuxStore`]); None without a cache.
    pub aux: Option<&'a dyn AuxStore>,
}

/// An operator's own data kept between runs in the run's persistent cache: what it makes from
/// its parameters alone, costs time to make and is no output (`ProbeSphere`'s frame plans: the
/// camera rays, hits and mirror reads of a frame, seconds to make, the same for every map). A
/// new process, a later checkpoint's run or a cluster's shard loads them instead of making them
/// again. The engine keys `name` under the operator (its name, version and code hash) and the
/// engine salt, so the data of other code is never served, and stores it as an ordinary cache
/// entry (checksummed, evicted with the others). Saving can fail silently (the cache's limit, a
/// full disk): the data is then made again next time.
pub trait AuxStore: Sync {
    /// The bytes saved under `name`, if the cache has them.
    fn load(&self, name: &str) -> Option<Vec<u8>>;
    /// Keeps `bytes` under `name`.
    fn save(&self, name: &str, bytes: Vec<u8>);
}

impl<'a> OpContext<'a> {
    /// Something the user should know that does not stop the node (input read in a surprising
    /// way, values clamped by a format): reported once, as `warning: node "NAME": MESSAGE`.
    pub fn warn(&mut self, message: impl Into<String>) {
        let message = message.into();
        if !self.warnings.contains(&message) {
            self.warnings.push(message);
        }
    }
    /// Hands back an input this operator has finished with before its own work is done (a `Save`
    /// that has made its 8-bit copy of an image, before the long deflate): the value is dropped
    /// now, and if this node was its last consumer the run counts its bytes as freed, so a node
    /// waiting for memory may start (see `scheduler::admission`). Pass the input's value
    /// (`p.image.into_value()`).
    pub fn release(&self, value: Value) {
        match self.release_to {
            Some(to) => to(value),
            None => drop(value),
        }
    }
    /// Whether anything in this run reads the output port `port` (a consumer that runs, or the
    /// caller). An operator may skip computing a port nobody reads and leave it out of its
    /// [`Outputs`](crate::engine::op::Outputs): demand-driven down to ports, so a merge whose confidence map no node uses
    /// never allocates it. The run stands a placeholder in its place, and the cache stores the
    /// other ports (a later run that reads the port computes the node again). A name that is
    /// not one of the node's ports is wanted.
    pub fn wants(&self, port: &str) -> bool {
        !self.unread_ports.contains(&port)
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
    /// How each value type is written as a file (the registry's savers: `Save` checks its path's
    /// extension against them).
    pub savers: &'a Savers,
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
