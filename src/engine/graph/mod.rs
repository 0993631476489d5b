//! Pipeline files: parsing (`syntax`), validation against the registry, and the petgraph DAG.
//!
//! A pipeline file is
//! ```ron
//! ( nodes: { "env": LoadHdr(path: "builtin:sky"), "lum": Luminance(image: "env") } )
//! ```
//! Validation checks, before any pixel is read: operator and field names, value types and
//! ranges, missing fields, that every input names an existing node, duplicate names, cycles, and
//! that the value wired into each input has an accepted type. Every problem is reported with the
//! file's line:column and the node's name, and all problems are reported at once.

pub mod syntax;
mod validate;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use petgraph::graph::{DiGraph, NodeIndex};

use crate::engine::error::{PipelineError, PipelineErrors};
use crate::engine::op::{OpSpec, Params};
use crate::engine::registry::Registry;
use crate::engine::value::ValueType;
use syntax::Pos;

/// A `--set NODE.FIELD=RON_VALUE` override, applied before validation.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    pub node: String,
    pub field: String,
    /// RON text of the value.
    pub value: String,
}

impl Override {
    /// Parses `NODE.FIELD=VALUE`.
    pub fn parse(s: &str) -> Result<Override, String> {
        let (lhs, value) = s.split_once('=').ok_or_else(|| format!("--set {s:?}: expected NODE.FIELD=VALUE"))?;
        let (node, field) = lhs.rsplit_once('.').ok_or_else(|| format!("--set {s:?}: expected NODE.FIELD=VALUE"))?;
        if node.is_empty() || field.is_empty() {
            return Err(format!("--set {s:?}: expected NODE.FIELD=VALUE"));
        }
        Ok(Override { node: node.to_string(), field: field.to_string(), value: value.to_string() })
    }
}

/// One validated node.
#[derive(Debug, Clone)]
pub struct Node {
    pub name: String,
    /// Position of the node's operator name in the file.
    pub pos: Pos,
    pub spec: &'static OpSpec,
    pub params: Params,
    /// Input field -> index of the node wired into it (into `Pipeline::nodes`).
    pub inputs: BTreeMap<&'static str, usize>,
    pub output_type: ValueType,
}

/// A validated pipeline: nodes in file order and the DAG of their dependencies.
#[derive(Debug, Clone)]
pub struct Pipeline {
    /// The file name as given by the user (used in messages).
    pub source: String,
    /// Relative paths in parameters resolve against this folder.
    pub base_dir: PathBuf,
    pub nodes: Vec<Node>,
    /// Edge a -> b: b consumes a's output. Node weights are indices into `nodes`.
    pub graph: DiGraph<usize, &'static str>,
    /// Node indices in a topological order (inputs before consumers).
    pub topo_order: Vec<usize>,
}

impl Pipeline {
    /// Reads and validates a pipeline file.
    pub fn load(path: &Path, registry: &Registry, overrides: &[Override]) -> Result<Pipeline, PipelineErrors> {
        let source = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| {
            PipelineErrors(vec![PipelineError {
                source: source.clone(),
                pos: None,
                node: None,
                message: e.to_string(),
            }])
        })?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Pipeline::parse(&text, &source, &base_dir, registry, overrides)
    }

    /// Validates pipeline text. `source` names it in messages; paths resolve against `base_dir`.
    pub fn parse(
        text: &str,
        source: &str,
        base_dir: &Path,
        registry: &Registry,
        overrides: &[Override],
    ) -> Result<Pipeline, PipelineErrors> {
        validate::validate(text, source, base_dir, registry, overrides)
    }

    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// The default targets: every node producing a file and every node nothing consumes.
    pub fn default_targets(&self) -> Vec<usize> {
        let mut consumed = vec![false; self.nodes.len()];
        for n in &self.nodes {
            for &i in n.inputs.values() {
                consumed[i] = true;
            }
        }
        (0..self.nodes.len()).filter(|&i| !consumed[i] || self.nodes[i].output_type == ValueType::File).collect()
    }

    /// Indices of nodes that consume node `i`.
    pub fn consumers(&self, i: usize) -> Vec<usize> {
        self.graph.neighbors_directed(NodeIndex::new(i), petgraph::Direction::Outgoing).map(|n| self.graph[n]).collect()
    }

    /// Graphviz DOT: one box per node (name and operator), edges labelled with input fields.
    pub fn to_dot(&self) -> String {
        let mut s = String::from("digraph pipeline {\n  rankdir=LR;\n  node [shape=box, fontname=\"sans-serif\"];\n");
        for n in &self.nodes {
            let label = format!("{}\n{} -> {}", n.name, n.spec.name, n.output_type);
            s.push_str(&format!("  {} [label={}];\n", dot_quote(&n.name), dot_quote(&label)));
        }
        for n in &self.nodes {
            for (field, &i) in &n.inputs {
                s.push_str(&format!(
                    "  {} -> {} [label={}];\n",
                    dot_quote(&self.nodes[i].name),
                    dot_quote(&n.name),
                    dot_quote(field)
                ));
            }
        }
        s.push_str("}\n");
        s
    }
}

/// A DOT quoted string: backslashes and quotes escaped, newlines as DOT's `\n`.
fn dot_quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}
