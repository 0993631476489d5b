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

pub use validate::{check_output_path, suggest};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use petgraph::graph::{DiGraph, NodeIndex};

use crate::engine::error::{PipelineError, PipelineErrors};
use crate::engine::op::OpSpec;
use crate::engine::params::{FieldKind, ParamValue, Params};
use crate::engine::registry::Registry;
use crate::engine::value::{Value, ValueType, FILE};
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

/// A reference to one output port of one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PortRef {
    /// Index into `Pipeline::nodes`.
    pub node: usize,
    /// Index into that node's `ports`.
    pub port: usize,
}

/// One output port of a validated node: a declared port, or an open port a consumer named.
#[derive(Clone, Debug, PartialEq)]
pub struct Port {
    /// A declared port's name is the operator's `&'static str`; only open ports own theirs.
    pub name: std::borrow::Cow<'static, str>,
    pub ty: ValueType,
}

/// The nodes wired into one input field, in order (empty: an optional input left unwired).
#[derive(Clone, Debug)]
pub struct InputWire {
    pub field: &'static str,
    pub sources: Vec<PortRef>,
}

/// One validated node.
#[derive(Debug, Clone)]
pub struct Node {
    pub name: String,
    /// Position of the node's operator name in the file.
    pub pos: Pos,
    pub spec: Arc<OpSpec>,
    pub params: Params,
    /// Every input field of the operator, in declaration order, with what is wired into it.
    pub inputs: Vec<InputWire>,
    /// Output ports: the declared ones, then open ports that consumers named. Port 0 is the
    /// default output.
    pub ports: Vec<Port>,
    /// The default output's pixel size, when known before running (from file headers and
    /// parameters); validation checks inputs that must agree in size with it.
    pub size: Option<(u64, u64)>,
}

impl Node {
    /// Every port wired into this node, in field order.
    pub fn sources(&self) -> impl Iterator<Item = PortRef> + '_ {
        self.inputs.iter().flat_map(|w| w.sources.iter().copied())
    }
    /// The type of the default output (None when the operator declares no port).
    pub fn output_type(&self) -> Option<ValueType> {
        self.ports.first().filter(|_| self.is_default_port(0)).map(|p| p.ty)
    }
    /// `node` for the default port, `node.port` for the others, as a user writes it.
    pub fn port_label(&self, port: usize) -> String {
        if self.is_default_port(port) {
            self.name.clone()
        } else {
            format!("{}.{}", self.name, self.ports[port].name)
        }
    }
    /// Whether port `port` is the default output, named by the bare node name. A node whose
    /// operator declares no output (only open ports, e.g. `SplitChannels`) has none: its port 0
    /// is the first open port a consumer named, and is written `node.port` like the others.
    pub fn is_default_port(&self, port: usize) -> bool {
        port == 0 && !self.spec.outputs.is_empty()
    }
    /// The pixel size of port `port` when known before running: the node's size for its
    /// default port and its open ports (channels of its image); no size fact for any other.
    pub fn port_size(&self, port: usize) -> Option<(u64, u64)> {
        let open = self.ports.get(port).is_none_or(|p| self.spec.port(&p.name).is_none());
        (self.is_default_port(port) || open).then_some(self.size).flatten()
    }

    /// Whether this node produces a file for the output folder.
    pub fn writes_file(&self) -> bool {
        self.ports.iter().any(|p| p.ty == ValueType(&FILE))
    }
}

/// A validated pipeline: nodes in file order and the DAG of their dependencies.
#[derive(Debug, Clone)]
pub struct Pipeline {
    /// The file name as given by the user (used in messages).
    pub source: String,
    /// Relative paths in parameters resolve against this folder.
    pub base_dir: PathBuf,
    pub nodes: Vec<Node>,
    /// Edge a -> b: b consumes one of a's ports. Node weights are indices into `nodes`.
    pub graph: DiGraph<usize, &'static str>,
    /// Node indices in a topological order (inputs before consumers).
    pub topo_order: Vec<usize>,
    /// The registry it was validated against (the cache decodes values with its types).
    pub registry: Registry,
    /// Values supplied by the caller in place of nodes' outputs (see [`Pipeline::provide`]):
    /// node index -> value of its one port.
    pub provided: BTreeMap<usize, Value>,
}

/// A node's input field -> the types of the values wired in, in order.
pub type InputTypes = BTreeMap<&'static str, Vec<ValueType>>;
/// A node's input field -> the pixel sizes of the values wired in, when known before running.
pub type InputSizes = BTreeMap<&'static str, Vec<Option<(u64, u64)>>>;

impl Pipeline {
    /// The types and known sizes ([`Node::port_size`]) of what is wired into node `i`: what its
    /// typed fields see before running, as validation saw them.
    pub fn input_shapes(&self, i: usize) -> (InputTypes, InputSizes) {
        let node = &self.nodes[i];
        let mut types = InputTypes::new();
        let mut sizes = InputSizes::new();
        for w in &node.inputs {
            let (t, s) = w
                .sources
                .iter()
                .map(|src| {
                    let producer = &self.nodes[src.node];
                    (producer.ports[src.port].ty, producer.port_size(src.port))
                })
                .unzip();
            types.insert(w.field, t);
            sizes.insert(w.field, s);
        }
        (types, sizes)
    }

    /// Reads and validates a pipeline file.
    pub fn load(path: &Path, registry: &Registry, overrides: &[Override]) -> Result<Pipeline, PipelineErrors> {
        Pipeline::load_providing(path, registry, overrides, &[])
    }

    /// [`load`](Self::load) for a caller that will [`provide`](Self::provide) the values of the
    /// nodes named in `provided`: their input files are never read, so they need not exist.
    pub fn load_providing(
        path: &Path,
        registry: &Registry,
        overrides: &[Override],
        provided: &[&str],
    ) -> Result<Pipeline, PipelineErrors> {
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
        Pipeline::parse_providing(&text, &source, &base_dir, registry, overrides, provided)
    }

    /// Validates pipeline text. `source` names it in messages; paths resolve against `base_dir`
    /// (and the files nodes read must exist).
    pub fn parse(
        text: &str,
        source: &str,
        base_dir: &Path,
        registry: &Registry,
        overrides: &[Override],
    ) -> Result<Pipeline, PipelineErrors> {
        validate::validate(text, source, base_dir, registry, overrides, &[])
    }

    /// [`parse`](Self::parse) for a caller that will [`provide`](Self::provide) the values of the
    /// nodes named in `provided`: their input files are never read, so they need not exist.
    pub fn parse_providing(
        text: &str,
        source: &str,
        base_dir: &Path,
        registry: &Registry,
        overrides: &[Override],
        provided: &[&str],
    ) -> Result<Pipeline, PipelineErrors> {
        validate::validate(text, source, base_dir, registry, overrides, provided)
    }

    /// Supplies node `name`'s value before running: the scheduler does not evaluate that node
    /// (nor what only it needs), uses `value` as its output, and keys it by the value's content
    /// (`cache::provided_key`), so the cache serves its consumers whenever the same value is
    /// supplied again. The value must have the type validation gave the node's output, and the
    /// node must have that one output port (consumers were checked against it). Used by the
    /// Python bindings to feed a NumPy array in place of a loader (validated with
    /// [`parse_providing`](Self::parse_providing), so that the loader's file need not exist).
    pub fn provide(&mut self, name: &str, value: Value) -> Result<(), String> {
        let i = self.index_of(name).ok_or_else(|| {
            let names: Vec<&str> = self.nodes.iter().map(|n| n.name.as_str()).collect();
            format!("no node {name:?} to provide a value for{}", suggest(name, &names, "nodes"))
        })?;
        let node = &self.nodes[i];
        if node.ports.len() != 1 {
            return Err(format!(
                "node {name:?} ({}) has {} output ports; a value can be provided only for a node with one",
                node.spec.name,
                node.ports.len()
            ));
        }
        let expected = node.ports[0].ty;
        if value.value_type() != expected {
            return Err(format!(
                "node {name:?} ({}) outputs `{expected}`, but the value provided is `{}`",
                node.spec.name,
                value.value_type()
            ));
        }
        self.provided.insert(i, value);
        Ok(())
    }

    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// The node a command-line target or `--print` names: `node`, or `node.port` for one of its
    /// declared or open ports, the same form as a field's (a whole name with dots wins).
    pub fn target_index(&self, name: &str) -> Option<usize> {
        self.index_of(name).or_else(|| {
            let (node, port) = name.rsplit_once('.')?;
            let i = self.index_of(node)?;
            let n = &self.nodes[i];
            (n.spec.port(port).is_some() || n.spec.open_ports.is_some()).then_some(i)
        })
    }

    /// Every name a target may be written as (for "did you mean"): nodes, and `node.port` for
    /// each declared port past the default.
    pub fn target_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.nodes.iter().map(|n| n.name.clone()).collect();
        for n in &self.nodes {
            names.extend(n.spec.outputs.iter().skip(1).map(|p| format!("{}.{}", n.name, p.name)));
        }
        names
    }

    /// The default targets: every node producing a file and every node nothing consumes.
    pub fn default_targets(&self) -> Vec<usize> {
        let mut consumed = vec![false; self.nodes.len()];
        for n in &self.nodes {
            for s in n.sources() {
                consumed[s.node] = true;
            }
        }
        (0..self.nodes.len()).filter(|&i| !consumed[i] || self.nodes[i].writes_file()).collect()
    }

    /// Indices of nodes that consume node `i` (once each).
    pub fn consumers(&self, i: usize) -> Vec<usize> {
        let mut v: Vec<usize> = self
            .graph
            .neighbors_directed(NodeIndex::new(i), petgraph::Direction::Outgoing)
            .map(|n| self.graph[n])
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Graphviz DOT: one box per node (name, operator, ports), edges labelled with input
    /// fields and the port they take.
    /// The files the pipeline reads: every input-path field's value, resolved against the
    /// pipeline's folder (`builtin:` names left out), sorted, without repeats.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = self
            .nodes
            .iter()
            .flat_map(|n| {
                n.spec.fields.iter().filter(|f| matches!(f.kind, FieldKind::Path)).filter_map(|f| {
                    match n.params.values.get(f.name) {
                        Some(ParamValue::Text(path)) if !path.starts_with("builtin:") => {
                            Some(crate::engine::op::resolve_path(&self.base_dir, path))
                        }
                        _ => None,
                    }
                })
            })
            .collect();
        v.sort();
        v.dedup();
        v
    }

    pub fn to_dot(&self) -> String {
        self.to_dot_styled(&|_| Vec::new())
    }

    /// [`to_dot`](Self::to_dot) with extra attributes per node, `(name, value)` pairs (a run
    /// report colours nodes by status); a `label` among them replaces the default label.
    pub fn to_dot_styled(&self, node_attrs: &dyn Fn(usize) -> Vec<(&'static str, String)>) -> String {
        let mut s = String::from("digraph pipeline {\n  rankdir=LR;\n  node [shape=box, fontname=\"sans-serif\"];\n");
        for (i, n) in self.nodes.iter().enumerate() {
            let extra = node_attrs(i);
            let label = match extra.iter().find(|(k, _)| *k == "label") {
                Some((_, l)) => l.clone(),
                None => {
                    let ports: Vec<String> = n.ports.iter().map(|p| format!("{}: {}", p.name, p.ty)).collect();
                    format!("{}\n{} -> {}", n.name, n.spec.name, ports.join(", "))
                }
            };
            let mut attrs = format!("label={}", dot_quote(&label));
            for (k, v) in extra.iter().filter(|(k, _)| *k != "label") {
                attrs.push_str(&format!(", {k}={}", dot_quote(v)));
            }
            s.push_str(&format!("  {} [{attrs}];\n", dot_quote(&n.name)));
        }
        for n in &self.nodes {
            for w in &n.inputs {
                for (k, src) in w.sources.iter().enumerate() {
                    let from = &self.nodes[src.node];
                    let mut label = w.field.to_string();
                    if w.sources.len() > 1 {
                        label.push_str(&format!("[{k}]"));
                    }
                    if !from.is_default_port(src.port) {
                        label = format!("{} <- {}", label, from.ports[src.port].name);
                    }
                    s.push_str(&format!(
                        "  {} -> {} [label={}];\n",
                        dot_quote(&from.name),
                        dot_quote(&n.name),
                        dot_quote(&label)
                    ));
                }
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
