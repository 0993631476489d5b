//! Errors of the engine's layers: pipeline files (with positions), runs, and the cache.

use std::fmt;
use std::path::PathBuf;

use crate::engine::graph::syntax::Pos;
use crate::engine::op::OpError;

/// One problem in a pipeline file, located by file, line:column and node.
#[derive(Debug, Clone, PartialEq)]
pub struct PipelineError {
    /// The pipeline file as the user named it (or `--set` for an override).
    pub source: String,
    pub pos: Option<Pos>,
    pub node: Option<String>,
    pub message: String,
}

impl fmt::Display for PipelineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.source)?;
        if let Some(p) = self.pos {
            write!(f, ":{}:{}", p.line, p.col)?;
        }
        write!(f, ": ")?;
        if let Some(n) = &self.node {
            write!(f, "node {n:?}: ")?;
        }
        f.write_str(&self.message)
    }
}

/// Every problem found in a pipeline file (validation reports them all, not just the first).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct PipelineErrors(pub Vec<PipelineError>);

impl fmt::Display for PipelineErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

/// A failure while running a validated pipeline.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("node {node:?} ({op}): {source}")]
    Op {
        node: String,
        op: &'static str,
        #[source]
        source: OpError,
    },
    /// An unknown `--target`, with a "did you mean" hint.
    #[error("unknown target node {0:?}{1}")]
    UnknownTarget(String, String),
    /// An operator broke its declaration (a missing port, a value of another type than
    /// declared): a bug in that operator.
    #[error("node {node:?} ({op}): {message} (a bug in the operator {op})")]
    Contract { node: String, op: &'static str, message: String },
    /// The output folder cannot receive files.
    #[error("output folder {}: {reason}", path.display())]
    OutputDir { path: PathBuf, reason: String },
    #[error("writing {}: {source}", path.display())]
    Output {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("refusing to write {0:?}: output paths must stay inside the output folder")]
    PathEscape(String),
    #[error("thread pool: {0}")]
    ThreadPool(String),
    #[error("a node panicked: {0} (this is a bug in hdrflow; please report it)")]
    Panic(String),
}

/// A cache entry that cannot be trusted or a cache folder that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("cache entry {} is corrupt: {reason}", path.display())]
    Corrupt { path: PathBuf, reason: String },
    /// This run has added as much as `--cache-limit-mb` allows.
    #[error("this run's cache limit of {limit_mb} MiB (--cache-limit-mb) is reached")]
    LimitReached { limit_mb: u64 },
    #[error("cache folder {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}
