//! The batch's metrics by node, beside `batch.csv` (which has one row per item):
//! - `metrics.csv`: one row per item and metrics node (`node` or `node.port`), one column per field,
//!   e.g. one row per map and material for the sphere protocol (`examples/evaluation/`);
//! - `summary.csv` and `summary.md`: per node and field, over the items that have it, the mean and
//!   its 95% confidence interval, mean +- t(0.975, n - 1) s / sqrt(n) with s the sample standard
//!   deviation (Student's t: the items are few), the table lighting-estimation papers print (a row
//!   per material, a column per metric). Non-finite values are left out of the mean and counted.

use std::collections::BTreeMap;

use statrs::distribution::{ContinuousCDF, StudentsT};

use super::report::csv_field;
use super::run::{ItemRow, ItemStatus};

/// `node.field` -> (`node`, `field`): the field is after the last dot.
fn split(label: &str) -> (&str, &str) {
    label.rsplit_once('.').unwrap_or(("", label))
}

/// Nodes and each node's fields, in the order the items first give them.
fn layout(rows: &[ItemRow]) -> Vec<(String, Vec<String>)> {
    let mut nodes: Vec<(String, Vec<String>)> = Vec::new();
    for (label, _) in rows.iter().flat_map(|r| &r.metrics) {
        let (node, field) = split(label);
        let i = match nodes.iter().position(|(n, _)| n == node) {
            Some(i) => i,
            None => {
                nodes.push((node.to_string(), Vec::new()));
                nodes.len() - 1
            }
        };
        if !nodes[i].1.iter().any(|f| f == field) {
            nodes[i].1.push(field.to_string());
        }
    }
    nodes
}

/// `metrics.csv` (module docs): item, index, node, then the fields of every node (empty where a
/// node has no such field). None when no item produced metrics.
pub fn metrics_csv(rows: &[ItemRow]) -> Option<String> {
    let nodes = layout(rows);
    if nodes.is_empty() {
        return None;
    }
    let mut fields: Vec<&str> = Vec::new();
    for f in nodes.iter().flat_map(|(_, fs)| fs) {
        if !fields.contains(&f.as_str()) {
            fields.push(f);
        }
    }
    let mut s = format!("item,index,node,{}\n", fields.iter().map(|f| csv_field(f)).collect::<Vec<_>>().join(","));
    for r in rows {
        let values: BTreeMap<&str, f64> = r.metrics.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        for (node, node_fields) in &nodes {
            if !node_fields.iter().any(|f| values.contains_key(format!("{node}.{f}").as_str())) {
                continue;
            }
            s.push_str(&format!("{},{},{}", csv_field(&r.item.dir), r.item.index, csv_field(node)));
            for f in &fields {
                s.push(',');
                if let Some(v) = values.get(format!("{node}.{f}").as_str()) {
                    s.push_str(&v.to_string());
                }
            }
            s.push('\n');
        }
    }
    Some(s)
}

/// The mean of a field over the items and its 95% interval.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldSummary {
    pub node: String,
    pub field: String,
    /// Finite values averaged.
    pub n: usize,
    /// Values left out because they were NaN or infinite.
    pub nonfinite: usize,
    pub mean: f64,
    /// Half the 95% interval's width; None with fewer than two values.
    pub half_width: Option<f64>,
}

/// Mean and 95% Student's t interval of `values` (module docs).
pub fn mean_interval(values: &[f64]) -> (f64, Option<f64>) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, None);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, None);
    }
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
    let t = StudentsT::new(0.0, 1.0, (n - 1) as f64).map(|d| d.inverse_cdf(0.975)).ok();
    (mean, t.map(|t| t * (var / n as f64).sqrt()))
}

/// Every node's fields over the items that succeeded.
pub fn summarise(rows: &[ItemRow]) -> Vec<FieldSummary> {
    let ok: Vec<&ItemRow> = rows.iter().filter(|r| r.status != ItemStatus::Failed).collect();
    let mut out = Vec::new();
    for (node, fields) in layout(rows) {
        for field in fields {
            let label = format!("{node}.{field}");
            let all: Vec<f64> =
                ok.iter().flat_map(|r| r.metrics.iter().filter(|(k, _)| *k == label).map(|(_, v)| *v)).collect();
            let finite: Vec<f64> = all.iter().copied().filter(|v| v.is_finite()).collect();
            let (mean, half_width) = mean_interval(&finite);
            out.push(FieldSummary {
                node: node.clone(),
                field,
                n: finite.len(),
                nonfinite: all.len() - finite.len(),
                mean,
                half_width,
            });
        }
    }
    out
}

/// `summary.csv`: node, field, n, nonfinite, mean, ci95_low, ci95_high (empty bounds with one value).
pub fn summary_csv(summary: &[FieldSummary]) -> String {
    let mut s = String::from("node,field,n,nonfinite,mean,ci95_low,ci95_high\n");
    for f in summary {
        let (lo, hi) = f
            .half_width
            .map_or((String::new(), String::new()), |h| ((f.mean - h).to_string(), (f.mean + h).to_string()));
        s.push_str(&format!(
            "{},{},{},{},{},{lo},{hi}\n",
            csv_field(&f.node),
            csv_field(&f.field),
            f.n,
            f.nonfinite,
            f.mean
        ));
    }
    s
}

/// Four significant digits, in scientific notation outside [1e-3, 1e5).
fn number(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        return "0".to_string();
    }
    if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

/// `summary.md`: a Markdown table, a row per node and a column per field, each cell
/// `mean ± half-width` (the 95% interval), and the number of items.
pub fn summary_markdown(summary: &[FieldSummary]) -> String {
    let mut nodes: Vec<&str> = Vec::new();
    let mut fields: Vec<&str> = Vec::new();
    for f in summary {
        if !nodes.contains(&f.node.as_str()) {
            nodes.push(&f.node);
        }
        if !fields.contains(&f.field.as_str()) {
            fields.push(&f.field);
        }
    }
    let mut s = format!("| | items | {} |\n|---|---|{}\n", fields.join(" | "), "---|".repeat(fields.len()));
    for node in nodes {
        let of_node: Vec<&FieldSummary> = summary.iter().filter(|f| f.node == node).collect();
        let n = of_node.iter().map(|f| f.n).max().unwrap_or(0);
        let cells: Vec<String> = fields
            .iter()
            .map(|field| match of_node.iter().find(|f| f.field == *field) {
                Some(f) if f.n > 0 => match f.half_width {
                    Some(h) => format!("{} ± {}", number(f.mean), number(h)),
                    None => number(f.mean),
                },
                _ => String::new(),
            })
            .collect();
        s.push_str(&format!("| {node} | {n} | {} |\n", cells.join(" | ")));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_interval_is_students_t_at_n_minus_one_degrees_of_freedom() {
        // 1, 2, 3: mean 2, s = 1, t(0.975, 2) = 4.302652729911275 (tables), half-width t / sqrt(3).
        let (mean, h) = mean_interval(&[1.0, 2.0, 3.0]);
        assert_eq!(mean, 2.0);
        let want = 4.302652729911275 / 3f64.sqrt();
        assert!((h.unwrap() - want).abs() < 1e-9, "{h:?} vs {want}");
        // Large n approaches the normal 1.959964 s / sqrt(n).
        let v: Vec<f64> = (0..10_000).map(|i| (i % 2) as f64).collect();
        let (_, h) = mean_interval(&v);
        let s = (0.25f64 * 10_000.0 / 9_999.0).sqrt();
        assert!((h.unwrap() / (s / 100.0) - 1.96).abs() < 1e-3);
        assert_eq!(mean_interval(&[5.0]), (5.0, None));
        assert!(mean_interval(&[]).0.is_nan());
    }

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(number(0.0123456), "0.01235");
        assert_eq!(number(12.3456), "12.35");
        assert_eq!(number(1234.5), "1234");
        assert_eq!(number(0.0), "0");
        assert_eq!(number(1.5e-7), "1.500e-7");
    }

    #[test]
    fn labels_split_at_the_last_dot() {
        assert_eq!(split("mirror.rmse"), ("mirror", "rmse"));
        assert_eq!(split("probe.metrics.rmse"), ("probe.metrics", "rmse"));
        assert_eq!(split("rmse"), ("", "rmse"));
    }
}
