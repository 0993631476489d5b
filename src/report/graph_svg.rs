//! The pipeline drawn as SVG, nodes coloured by their status in a run.
//!
//! Graphviz (`dot -Tsvg`) lays it out when it is installed (the better drawing); otherwise the
//! `layout-rs` crate, a pure-Rust implementation of the same layered (Sugiyama) layout, reads the
//! same DOT text. Either way the page needs nothing at view time.

use std::io::Write;
use std::process::{Command, Stdio};

use crate::engine::graph::Pipeline;
use crate::engine::scheduler::{NodeStatus, RunReport};

/// Fill colour of a node by status (the legend of the page uses the same).
pub fn status_colour(status: NodeStatus) -> &'static str {
    match status {
        NodeStatus::Computed => "#a6e3a1",
        NodeStatus::Cached => "#89b4fa",
        NodeStatus::NotNeeded => "#e5e5e5",
        NodeStatus::Provided => "#f9e2af",
    }
}

/// Which program laid the graph out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    Graphviz,
    LayoutRs,
}

/// The pipeline as DOT, each node labelled with its name, operator and compute time, and filled
/// by its status in `report` (white when the report lacks it, as after a failed run).
pub fn styled_dot(p: &Pipeline, report: Option<&RunReport>) -> String {
    p.to_dot_styled(&|i| {
        let node = &p.nodes[i];
        // A run's report lists the pipeline's nodes in order.
        let reported = report.and_then(|r| r.nodes.get(i)).filter(|n| n.name == node.name);
        let fill = reported.map_or("#ffffff", |n| status_colour(n.status));
        let label = match reported {
            Some(n) if n.status == NodeStatus::Computed => format!("{}\n{} {:.1} ms", node.name, node.spec.name, n.ms),
            _ => format!("{}\n{}", node.name, node.spec.name),
        };
        vec![("label", label), ("style", "filled".to_string()), ("fillcolor", fill.to_string())]
    })
}

/// The graph as an `<svg>` element (no XML prolog), and what laid it out.
pub fn render(p: &Pipeline, report: Option<&RunReport>) -> (String, Layout) {
    let dot = styled_dot(p, report);
    if let Some(svg) = graphviz(&dot) {
        return (svg, Layout::Graphviz);
    }
    (layout_rs(&dot), Layout::LayoutRs)
}

/// `dot -Tsvg`, or `None` when Graphviz is not installed or fails.
fn graphviz(dot: &str) -> Option<String> {
    let mut child = Command::new("dot")
        .arg("-Tsvg")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    child.stdin.take()?.write_all(dot.as_bytes()).ok()?;
    let out = child.wait_with_output().ok()?;
    if !out.status.success() {
        return None;
    }
    strip_prolog(&String::from_utf8_lossy(&out.stdout))
}

/// The same DOT laid out by `layout-rs`.
fn layout_rs(dot: &str) -> String {
    use layout::backends::svg::SVGWriter;
    use layout::gv::{DotParser, GraphBuilder};
    let mut parser = DotParser::new(dot);
    let Ok(graph) = parser.process() else {
        // Our own DOT always parses; should it not, the page says so instead of failing.
        return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"400\" height=\"20\"><text y=\"15\">the graph could not be laid out</text></svg>".into();
    };
    let mut builder = GraphBuilder::new();
    builder.visit_graph(&graph);
    let mut visual = builder.get();
    let mut svg = SVGWriter::new();
    visual.do_it(false, false, false, &mut svg);
    strip_prolog(&svg.finalize()).unwrap_or_default()
}

/// From `<svg` on (drops `<?xml ...?>` and a DOCTYPE, which may not appear inside HTML).
fn strip_prolog(svg: &str) -> Option<String> {
    svg.find("<svg").map(|i| svg[i..].to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_rs_draws_every_node_with_its_colour() {
        let dot = "digraph g { \"a\" [label=\"a\\nOp\", style=\"filled\", fillcolor=\"#a6e3a1\"]; \"b\" [label=\"b\"]; \"a\" -> \"b\" [label=\"x\"]; }";
        let svg = layout_rs(dot);
        assert!(svg.starts_with("<svg"), "{svg}");
        assert!(svg.contains(">a<") || svg.contains(">a\n"), "{svg}");
        assert!(svg.to_ascii_lowercase().contains("a6e3a1"), "{svg}");
    }

    #[test]
    fn the_prolog_is_dropped() {
        assert_eq!(strip_prolog("<?xml version=\"1.0\"?>\n<!DOCTYPE svg>\n<svg a>").as_deref(), Some("<svg a>"));
        assert_eq!(strip_prolog("no svg"), None);
    }
}
