//! `--html FILE`: one self-contained page per run, readable offline (no script or style from a
//! network, images inlined as data URIs, each linked to its file):
//!
//! - the graph as SVG, nodes coloured by status (see [`super::graph_svg`]);
//! - every image output as a tone-mapped thumbnail ([`super::thumbnail`]), plots included;
//!   metrics JSON files as tables, CSV files as their first rows;
//! - a table of every node: operator, status, time, whether it was stored, cache key;
//! - the timeline of the parallel schedule: one lane per worker thread, one bar per computed node.
//!
//! Under `hdrflow watch` the page reloads itself every second (`<meta http-equiv="refresh">`:
//! browsers forbid scripts on `file://` pages from polling files), and it is replaced atomically
//! after each rerun, so a reload never sees half a page.

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use base64::Engine as _;

use super::graph_svg::{self, status_colour, Layout};
use super::thumbnail;
use crate::engine::graph::Pipeline;
use crate::engine::scheduler::{NodeStatus, RunReport};

/// Everything a page shows.
pub struct Page<'a> {
    /// The pipeline file as given.
    pub title: String,
    /// The validated pipeline (None when it did not validate: the page shows the error).
    pub pipeline: Option<&'a Pipeline>,
    pub report: Option<&'a RunReport>,
    /// The run's output folder (file links and thumbnails).
    pub out_dir: &'a Path,
    /// An error to show above everything (validation or run error).
    pub error: Option<String>,
    /// Reload the page every this many seconds (watch mode).
    pub refresh_seconds: Option<u32>,
    /// "run 3 at 12:04:05" and the like.
    pub subtitle: String,
}

/// Writes the page to `path` atomically.
pub fn write(path: &Path, page: &Page) -> std::io::Result<()> {
    let html = render(path, page);
    crate::engine::cache::store::write_atomic(path, html.as_bytes())
}

/// The page as HTML text; links are relative to `html_path`'s folder.
pub fn render(html_path: &Path, page: &Page) -> String {
    let mut h = String::with_capacity(64 * 1024);
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    if let Some(s) = page.refresh_seconds {
        let _ = writeln!(h, "<meta http-equiv=\"refresh\" content=\"{s}\">");
    }
    let _ = writeln!(h, "<title>hdrflow: {}</title>", esc(&page.title));
    h.push_str(STYLE);
    h.push_str("</head>\n<body>\n");
    let _ = writeln!(h, "<h1>{}</h1>\n<p class=\"sub\">{}</p>", esc(&page.title), esc(&page.subtitle));
    if let Some(e) = &page.error {
        let _ = writeln!(h, "<pre class=\"error\" id=\"error\">{}</pre>", esc(e));
    }
    if let Some(r) = page.report {
        let count = |s| r.count(s);
        let _ = writeln!(
            h,
            "<p class=\"summary\">{} nodes: {} computed, {} cached, {} not needed; {:.1} ms</p>",
            r.nodes.len(),
            count(NodeStatus::Computed),
            count(NodeStatus::Cached),
            count(NodeStatus::NotNeeded),
            r.total_ms
        );
    }
    if let Some(p) = page.pipeline {
        let (svg, layout) = graph_svg::render(p, page.report);
        let by = match layout {
            Layout::Graphviz => "Graphviz",
            Layout::LayoutRs => "layout-rs",
        };
        let _ = writeln!(h, "<h2>Graph</h2>\n{}", legend());
        let _ = writeln!(h, "<div id=\"graph\" class=\"graph\" data-layout=\"{by}\">{svg}</div>");
        let names: Vec<String> = p.nodes.iter().map(|n| format!("\"{}\"", js_esc(&n.name))).collect();
        let _ = writeln!(h, "<script>window.hdrflowNodes = [{}];</script>", names.join(","));
    }
    if let Some(r) = page.report {
        outputs(&mut h, html_path, page.out_dir, r);
        node_table(&mut h, r);
        timeline(&mut h, r);
    }
    h.push_str(CHECK_SCRIPT);
    h.push_str("</body>\n</html>\n");
    h
}

fn legend() -> String {
    let item =
        |s: NodeStatus| format!("<span class=\"swatch\" style=\"background:{}\"></span>{}", status_colour(s), s.word());
    format!(
        "<p class=\"legend\">{} {} {}</p>",
        item(NodeStatus::Computed),
        item(NodeStatus::Cached),
        item(NodeStatus::NotNeeded)
    )
}

/// The output files: thumbnails for images, tables for metrics, first rows of CSVs.
fn outputs(h: &mut String, html_path: &Path, out_dir: &Path, r: &RunReport) {
    if r.files.is_empty() {
        return;
    }
    h.push_str("<h2>Outputs</h2>\n<div class=\"outputs\">\n");
    // Images first, then metrics and other JSON, then text; in file order within each.
    let rank = |rel: &str| match rel.rsplit('.').next().unwrap_or("").to_ascii_lowercase().as_str() {
        "png" | "exr" | "hdr" | "pfm" | "pic" | "rgbe" => 0,
        "json" => 1,
        _ => 2,
    };
    let mut files: Vec<&(String, String)> = r.files.iter().collect();
    files.sort_by_key(|(_, rel)| rank(rel));
    for (node, rel) in files {
        let path = out_dir.join(rel);
        let href = link(html_path, &path);
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let _ = write!(
            h,
            "<figure class=\"output\"><figcaption><a href=\"{}\">{}</a> <span class=\"node\">{}</span></figcaption>",
            esc(&href),
            esc(rel),
            esc(node)
        );
        match ext.as_str() {
            "png" | "exr" | "hdr" | "pfm" | "pic" | "rgbe" => match thumbnail::of_file(&path) {
                Some(png) => {
                    let data = base64::engine::general_purpose::STANDARD.encode(png);
                    let _ = write!(
                        h,
                        "<a href=\"{}\"><img class=\"thumb\" alt=\"{}\" src=\"data:image/png;base64,{data}\"></a>",
                        esc(&href),
                        esc(rel)
                    );
                }
                None => h.push_str("<p class=\"note\">(no preview: the file could not be read)</p>"),
            },
            "json" => json_preview(h, &path),
            "csv" | "txt" => text_preview(h, &path, 8),
            _ => {}
        }
        h.push_str("</figure>\n");
    }
    h.push_str("</div>\n");
}

/// A JSON object of numbers (a `Metrics` file) as a table; anything else as text.
fn json_preview(h: &mut String, path: &Path) {
    let Ok(text) = std::fs::read_to_string(path) else { return };
    match serde_json::from_str::<serde_json::Value>(&text) {
        Ok(serde_json::Value::Object(map)) if map.values().all(|v| v.is_number() || v.is_string()) => {
            h.push_str("<table class=\"metrics\">");
            for (k, v) in &map {
                let shown = match v {
                    serde_json::Value::Number(n) => n.as_f64().map_or_else(|| n.to_string(), fmt_number),
                    other => other.to_string(),
                };
                let _ = write!(h, "<tr><th>{}</th><td>{}</td></tr>", esc(k), esc(&shown));
            }
            h.push_str("</table>");
        }
        _ => text_preview(h, path, 12),
    }
}

fn fmt_number(x: f64) -> String {
    if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e6) {
        format!("{x:.6e}")
    } else {
        format!("{x:.6}")
    }
}

fn text_preview(h: &mut String, path: &Path, lines: usize) {
    let Ok(text) = std::fs::read_to_string(path) else { return };
    let total = text.lines().count();
    let head: Vec<String> = text.lines().take(lines).map(|l| l.chars().take(160).collect()).collect();
    let more = if total > lines { format!("\n... {} more lines", total - lines) } else { String::new() };
    let _ = write!(h, "<pre class=\"text\">{}{}</pre>", esc(&head.join("\n")), esc(&more));
}

fn node_table(h: &mut String, r: &RunReport) {
    h.push_str("<h2>Nodes</h2>\n<table class=\"nodes\"><tr><th>node</th><th>operator</th><th>status</th><th>ms</th><th>stored</th><th>key</th></tr>\n");
    for n in &r.nodes {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td><span class=\"swatch\" style=\"background:{}\"></span>{}</td><td class=\"num\">{:.2}</td><td>{}</td><td class=\"key\">{}</td></tr>",
            esc(&n.name),
            esc(n.op),
            status_colour(n.status),
            n.status.word(),
            n.ms,
            if n.stored { "yes" } else { "" },
            esc(&n.key[..n.key.len().min(16)])
        );
    }
    h.push_str("</table>\n");
}

/// The parallel schedule: one lane per worker thread, one bar per computed node at its start
/// time and duration.
fn timeline(h: &mut String, r: &RunReport) {
    let computed: Vec<_> = r.nodes.iter().filter(|n| n.status == NodeStatus::Computed).collect();
    if computed.is_empty() {
        h.push_str(
            "<h2>Timeline</h2>\n<p class=\"note\">Nothing was computed: every needed node came from the cache.</p>\n",
        );
        return;
    }
    let mut lanes: Vec<Option<usize>> = computed.iter().map(|n| n.thread).collect();
    lanes.sort();
    lanes.dedup();
    let end = computed.iter().map(|n| n.start_ms + n.ms).fold(r.total_ms, f64::max).max(1e-3);
    let (left, width, lane_h) = (90.0, 900.0, 22.0);
    let height = lane_h * lanes.len() as f64 + 24.0;
    let _ = writeln!(h, "<h2>Timeline</h2>\n<svg id=\"timeline\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{height}\" font-size=\"11\" font-family=\"sans-serif\">", left + width + 10.0);
    for (k, lane) in lanes.iter().enumerate() {
        let y = k as f64 * lane_h;
        let label = lane.map_or("caller".to_string(), |t| format!("thread {t}"));
        let _ = writeln!(h, "<text x=\"4\" y=\"{}\">{label}</text>", y + 15.0);
        let _ = writeln!(
            h,
            "<line x1=\"{left}\" x2=\"{}\" y1=\"{}\" y2=\"{}\" stroke=\"#ddd\"/>",
            left + width,
            y + lane_h,
            y + lane_h
        );
    }
    for n in &computed {
        let k = lanes.iter().position(|l| *l == n.thread).unwrap_or(0);
        let x = left + n.start_ms / end * width;
        let w = (n.ms / end * width).max(1.0);
        let y = k as f64 * lane_h + 3.0;
        let _ = write!(
            h,
            "<g><title>{} ({}): {:.2} ms, from {:.2} ms</title><rect x=\"{x:.1}\" y=\"{y}\" width=\"{w:.1}\" height=\"{}\" fill=\"{}\" stroke=\"#333\" stroke-width=\"0.5\"/>",
            esc(&n.name),
            esc(n.op),
            n.ms,
            n.start_ms,
            lane_h - 6.0,
            status_colour(NodeStatus::Computed)
        );
        if w > 7.0 * n.name.len() as f64 {
            let _ = write!(h, "<text x=\"{:.1}\" y=\"{}\">{}</text>", x + 3.0, y + 12.0, esc(&n.name));
        }
        h.push_str("</g>\n");
    }
    let _ = writeln!(
        h,
        "<text x=\"{left}\" y=\"{}\">0 ms</text><text x=\"{}\" y=\"{}\" text-anchor=\"end\">{end:.1} ms</text>\n</svg>",
        height - 4.0,
        left + width,
        height - 4.0
    );
}

/// A link from the page's folder to `target`: relative when both are under one root, else a
/// `file://` URL.
fn link(html_path: &Path, target: &Path) -> String {
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let from = abs(html_path.parent().unwrap_or(Path::new(".")));
    let to = abs(target);
    let norm = |p: &Path| -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for c in p.components() {
            match c {
                Component::ParentDir => {
                    v.pop();
                }
                Component::Normal(s) => v.push(s.to_string_lossy().into_owned()),
                _ => {}
            }
        }
        v
    };
    let (f, t) = (norm(&from), norm(&to));
    let common = f.iter().zip(&t).take_while(|(a, b)| a == b).count();
    let mut rel = PathBuf::new();
    for _ in common..f.len() {
        rel.push("..");
    }
    for part in &t[common..] {
        rel.push(part);
    }
    rel.components().map(|c| url_part(&c.as_os_str().to_string_lossy())).collect::<Vec<_>>().join("/")
}

/// Percent-encodes what may not appear raw in a URL path segment.
fn url_part(s: &str) -> String {
    let mut out = String::new();
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

/// HTML text escaping.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Inside a double-quoted JavaScript string in a `<script>` element.
fn js_esc(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"").replace('<', "\\u003c").replace('\n', "\\n")
}

const STYLE: &str = r#"<style>
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
h1 { font-size: 1.4em; margin-bottom: 0; } h2 { font-size: 1.15em; margin-top: 1.6em; }
.sub, .note { color: #666; } .summary { font-weight: 600; }
.error { background: #fde2e1; border: 1px solid #e5a1a1; padding: 0.8em; white-space: pre-wrap; }
.graph { overflow-x: auto; border: 1px solid #eee; padding: 0.5em; }
.graph svg { max-width: 100%; height: auto; }
.legend .swatch, td .swatch { display: inline-block; width: 0.9em; height: 0.9em; margin: 0 0.3em 0 0.8em; border: 1px solid #888; vertical-align: middle; }
.outputs { display: flex; flex-wrap: wrap; gap: 1em; }
.output { margin: 0; border: 1px solid #eee; padding: 0.5em; max-width: 340px; }
.output figcaption { font-size: 0.85em; margin-bottom: 0.3em; word-break: break-all; }
.output .node { color: #888; }
.thumb { max-width: 320px; max-height: 320px; display: block; }
table { border-collapse: collapse; font-size: 0.85em; }
td, th { border-bottom: 1px solid #eee; padding: 0.2em 0.6em; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; } td.key { font-family: monospace; color: #777; }
pre.text { font-size: 0.8em; max-width: 320px; overflow-x: auto; }
</style>
"#;

/// Marks on `<body>` what loaded, for a headless browser to check (`tests/html_report.rs`):
/// `data-images="loaded/total"` and `data-graph-nodes="found/total"` (node names drawn in the
/// graph's SVG text; Graphviz writes a `<text>` per label line, layout-rs a `<tspan>`).
const CHECK_SCRIPT: &str = r##"<script>
window.addEventListener("load", function () {
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) { if (imgs[i].complete && imgs[i].naturalWidth > 0) ok++; }
  document.body.setAttribute("data-images", ok + "/" + imgs.length);
  var names = window.hdrflowNodes || [], texts = {}, found = 0;
  var ts = document.querySelectorAll("#graph svg text, #graph svg tspan");
  for (var j = 0; j < ts.length; j++) { texts[ts[j].textContent.trim()] = true; }
  for (var k = 0; k < names.length; k++) { if (texts[names[k]]) found++; }
  document.body.setAttribute("data-graph-nodes", found + "/" + names.length);
});
</script>
"##;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_are_relative_and_encoded() {
        assert_eq!(link(Path::new("/a/out/report.html"), Path::new("/a/out/em 64.png")), "em%2064.png");
        assert_eq!(link(Path::new("/a/r/report.html"), Path::new("/a/out/x/y.exr")), "../out/x/y.exr");
    }

    #[test]
    fn escaping() {
        assert_eq!(esc("<a href=\"x\">&</a>"), "&lt;a href=&quot;x&quot;&gt;&amp;&lt;/a&gt;");
        assert_eq!(js_esc("a\"</script>"), "a\\\"\\u003c/script>");
        assert_eq!(fmt_number(0.5), "0.500000");
        assert_eq!(fmt_number(1e-5), "1.000000e-5");
    }
}
