//! The batch report: one row per item as JSON (`--report`) and as CSV (`batch.csv`).

use std::collections::{BTreeMap, BTreeSet};

use super::run::ItemRow;

/// The report rows as JSON values (item, index, values, status, ms, error, metrics).
pub fn json_rows(rows: &[ItemRow]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                let values: serde_json::Map<String, serde_json::Value> =
                    r.item.values.iter().map(|(k, v)| (k.clone(), v.clone().into())).collect();
                let metrics: serde_json::Map<String, serde_json::Value> =
                    r.metrics.iter().map(|(k, v)| (k.clone(), (*v).into())).collect();
                serde_json::json!({
                    "item": r.item.dir,
                    "index": r.item.index,
                    "values": values,
                    "status": r.status.word(),
                    "ms": r.ms,
                    "error": r.error,
                    "evaluations": r.evaluations,
                    "metrics": metrics,
                })
            })
            .collect(),
    )
}

/// A CSV cell: quoted (quotes doubled) when it holds a comma, a quote or a newline.
pub(super) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The report as CSV: item, index, values (`NODE.FIELD=value` joined by `;`), status, ms,
/// error, then one column per metrics field (`node.field`), sorted.
pub fn csv(rows: &[ItemRow]) -> String {
    let columns: BTreeSet<&str> = rows.iter().flat_map(|r| r.metrics.iter().map(|(k, _)| k.as_str())).collect();
    let mut s = String::from("item,index,values,status,ms,error");
    for c in &columns {
        s.push(',');
        s.push_str(&csv_field(c));
    }
    s.push('\n');
    for r in rows {
        let values: Vec<String> = r.item.values.iter().map(|(k, v)| format!("{k}={v}")).collect();
        s.push_str(&format!(
            "{},{},{},{},{:.3},{}",
            csv_field(&r.item.dir),
            r.item.index,
            csv_field(&values.join(";")),
            r.status.word(),
            r.ms,
            csv_field(r.error.as_deref().unwrap_or(""))
        ));
        let m: BTreeMap<&str, f64> = r.metrics.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        for c in &columns {
            s.push(',');
            if let Some(v) = m.get(c) {
                s.push_str(&v.to_string());
            }
        }
        s.push('\n');
    }
    s
}
