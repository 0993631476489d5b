//! Pipeline validation: syntax tree -> typed, acyclic `Pipeline`, or every problem with its
//! position. The phases, each in its own file:
//!
//! 1. `top_level`: the file is `( nodes: { "name": Operator(...), ... } )`.
//! 2. `collect_nodes`: names (unique, non-empty) and operators (known).
//! 3. `apply_overrides`: `--set NODE.FIELD=VALUE` replaces or adds one field.
//! 4. `resolve_fields`: each field is known, parameters convert to their kind and range, inputs
//!    name existing nodes and ports, with the declared arity; defaults fill the rest.
//! 5. `build_dag`: the petgraph DAG and a topological order, or every cycle.
//! 6. `infer_types`: in topological order, each input receives a type its field accepts, the
//!    operator's own check runs, and each output port gets its type.
//! 7. `check_outputs`: no two nodes write the same output path.
//! 8. `check_input_files`: every file a node reads exists and is a file (but for nodes whose
//!    values the caller provides).
//!
//! No phase recurses over the graph, so a 100000-node chain validates in linear time.

mod convert;
mod dag;
mod fields;
mod inputs;
mod nodes;
mod outputs;
mod suggest;
mod types;

use std::path::Path;
use std::sync::Arc;

use super::syntax::{self, Pos, Ron, Spanned};
use super::{Override, Pipeline};
use crate::engine::error::{PipelineError, PipelineErrors};
use crate::engine::op::OpSpec;
use crate::engine::registry::Registry;

pub use outputs::check_output_path;
pub use suggest::suggest;

/// A node as written, before its fields are checked.
struct RawNode {
    name: String,
    op_pos: Pos,
    spec: Arc<OpSpec>,
    /// (field name with its position, value, where it came from: the file or a `--set`).
    fields: Vec<(Spanned<String>, Spanned<Ron>, Origin)>,
}

/// Where a field came from: the pipeline file's name or `--set NODE.FIELD` (shared, not copied
/// per field).
type Origin = std::rc::Rc<str>;

/// A port name: declared ones borrowed from the operator's spec, open ones owned.
type PortName = std::borrow::Cow<'static, str>;

/// A reference to a node's port as written, before ports are resolved to indices.
struct WrittenRef {
    node: usize,
    port: PortName,
    pos: Pos,
    origin: Origin,
}

/// Every problem found so far.
struct Collector<'a> {
    source: &'a str,
    errors: Vec<PipelineError>,
}

impl Collector<'_> {
    fn push(&mut self, pos: Option<Pos>, node: Option<&str>, message: impl Into<String>) {
        let source = self.source.to_string();
        self.push_from(&source, pos, node, message);
    }
    /// Like `push`, for a problem from `origin` (the file or a `--set`); line 0 means no position.
    fn push_from(&mut self, origin: &str, pos: Option<Pos>, node: Option<&str>, message: impl Into<String>) {
        self.errors.push(PipelineError {
            source: origin.to_string(),
            pos: pos.filter(|p| p.line > 0),
            node: node.map(str::to_string),
            message: message.into(),
        });
    }
    /// Every problem, in the order of the file (a `--set` after the file's; problems without a
    /// position first within their origin). The sort is stable: one position's problems keep the
    /// order they were found in.
    fn fail(mut self) -> PipelineErrors {
        let source = self.source;
        self.errors.sort_by_key(|e| (e.source != source, e.pos.map_or((0, 0), |p| (p.line, p.col))));
        PipelineErrors(self.errors)
    }
}

pub(super) fn validate(
    text: &str,
    source: &str,
    base_dir: &Path,
    registry: &Registry,
    overrides: &[Override],
    provided: &[&str],
) -> Result<Pipeline, PipelineErrors> {
    let mut errs = Collector { source, errors: Vec::new() };
    let root = syntax::parse(text).map_err(|e| {
        PipelineErrors(vec![PipelineError {
            source: source.to_string(),
            pos: Some(e.pos),
            node: None,
            message: e.message,
        }])
    })?;
    let Some(entries) = nodes::top_level(root, &mut errs) else { return Err(errs.fail()) };
    let (mut raw, all_names) = nodes::collect_nodes(entries, registry, &mut errs);
    nodes::apply_overrides(&mut raw, &all_names, overrides, &mut errs);
    // Every later phase runs whatever the earlier ones found, on the nodes not in error, so that
    // one run reports every problem the file has.
    let mut resolved = fields::resolve_fields(&raw, &all_names, source, &mut errs);
    let dag = dag::build_dag(&resolved.nodes, &mut errs);
    if let Some((_, topo_order)) = &dag {
        types::infer_types(&mut resolved, &raw, topo_order, base_dir, registry.savers(), &mut errs);
    }
    outputs::check_outputs(&resolved.nodes, &raw, &mut errs);
    inputs::check_input_files(&resolved.nodes, &raw, base_dir, provided, &mut errs);
    let Some((graph, topo_order)) = dag.filter(|_| errs.errors.is_empty()) else {
        return Err(errs.fail());
    };
    Ok(Pipeline {
        source: source.to_string(),
        base_dir: base_dir.to_path_buf(),
        nodes: resolved.nodes,
        graph,
        topo_order,
        registry: registry.clone(),
        provided: Default::default(),
    })
}
