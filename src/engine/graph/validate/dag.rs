//! Phase 5: the petgraph DAG and a topological order, or every cycle.

use petgraph::graph::DiGraph;

use super::Collector;
use crate::engine::graph::Node;

/// Phase 5: the DAG and a topological order; on cycles, every elementary cycle found.
pub(super) fn build_dag(nodes: &[Node], errs: &mut Collector) -> Option<(DiGraph<usize, &'static str>, Vec<usize>)> {
    let mut graph: DiGraph<usize, &'static str> = DiGraph::with_capacity(nodes.len(), nodes.len());
    let ids: Vec<_> = (0..nodes.len()).map(|i| graph.add_node(i)).collect();
    for (i, n) in nodes.iter().enumerate() {
        for w in &n.inputs {
            for s in &w.sources {
                graph.add_edge(ids[s.node], ids[i], w.field);
            }
        }
    }
    match petgraph::algo::toposort(&graph, None) {
        Ok(order) => {
            let order = order.into_iter().map(|id| graph[id]).collect();
            Some((graph, order))
        }
        Err(_) => {
            for cycle in find_cycles(nodes) {
                let names: Vec<&str> = cycle.iter().map(|&i| nodes[i].name.as_str()).collect();
                let first = cycle[0];
                errs.push(Some(nodes[first].pos), Some(&nodes[first].name), format!("cycle: {}", names.join(" -> ")));
            }
            None
        }
    }
}

/// Every elementary cycle reachable by DFS, each once, as node indices in edge order
/// (a -> b means b consumes a), closed by repeating its first node. petgraph's toposort names
/// only one node of a cycle; users need the whole loop. Iterative (an explicit stack), so a
/// long chain cannot overflow the thread's stack.
fn find_cycles(nodes: &[Node]) -> Vec<Vec<usize>> {
    let mut consumers = vec![Vec::new(); nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        for s in n.sources() {
            consumers[s.node].push(i);
        }
    }
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Active,
        Done,
    }
    let mut mark = vec![Mark::New; nodes.len()];
    let mut cycles = Vec::new();
    for root in 0..nodes.len() {
        if mark[root] != Mark::New {
            continue;
        }
        // (node, index of the next consumer to visit)
        let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
        mark[root] = Mark::Active;
        while let Some(&mut (v, ref mut next)) = stack.last_mut() {
            if let Some(&w) = consumers[v].get(*next) {
                *next += 1;
                match mark[w] {
                    Mark::New => {
                        mark[w] = Mark::Active;
                        stack.push((w, 0));
                    }
                    Mark::Active => {
                        let start = stack.iter().position(|&(s, _)| s == w).expect("active node is on the stack");
                        let mut cycle: Vec<usize> = stack[start..].iter().map(|&(s, _)| s).collect();
                        cycle.push(w);
                        cycles.push(cycle);
                    }
                    Mark::Done => {}
                }
            } else {
                mark[v] = Mark::Done;
                stack.pop();
            }
        }
    }
    cycles
}
