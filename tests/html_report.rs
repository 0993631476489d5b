//! `hdrflow run --html`: the page of a seed run, opened in headless Chromium (Debian's `chromium`,
//! installed by `.ci/run`): every image loaded, every node drawn in the graph; a screenshot is
//! kept as a CI artefact (`target/tmp/html-report.png`). Without Chromium the browser part says
//! loudly that it skipped, unless `HDRFLOW_REQUIRE_CHROMIUM=1` (set by `.ci/run`).

mod common;

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use common::*;

fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"].into_iter().find(|c| {
        Command::new("sh").arg("-c").arg(format!("command -v {c}")).output().is_ok_and(|o| o.status.success())
    })
}

/// Headless Chromium on a local page (`--no-sandbox`: CI runs as root).
fn headless(browser: &str, page: &Path, extra: &[&str]) -> Output {
    let mut cmd = Command::new(browser);
    cmd.args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--virtual-time-budget=5000"])
        .args(extra)
        .arg(format!("file://{}", page.display()));
    run_command(cmd, Duration::from_secs(90))
}

/// The value of `name="..."` on the dumped `<body>` tag.
fn body_attr(dom: &str, name: &str) -> Option<String> {
    let body = &dom[dom.find("<body")?..];
    let tag = &body[..body.find('>')?];
    let at = tag.find(&format!("{name}=\""))? + name.len() + 2;
    Some(tag[at..at + tag[at..].find('"')?].to_string())
}

#[test]
fn the_seed_page_shows_every_image_and_node_in_a_real_browser() {
    let sb = Sandbox::new();
    let graph = Path::new(MANIFEST_DIR).join("graphs/seed.ron");
    let page = sb.join("report/seed.html");
    let (_, report) = sb.run_ok(&graph, &["--html", page.to_str().unwrap()]);
    let html = std::fs::read_to_string(&page).unwrap();
    let images = files_under(&sb.out())
        .into_iter()
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("png" | "exr" | "pfm" | "hdr")))
        .count();
    assert!(images >= 10, "{images} image outputs");
    assert_eq!(html.matches("<img ").count(), images, "one thumbnail per image output");
    assert!(html.contains("id=\"graph\"") && html.contains("<svg"), "the graph is drawn");
    assert!(html.contains("id=\"timeline\""), "the schedule is drawn");
    assert!(html.contains("href=\"../out/em_64.png\""), "outputs are linked relative to the page");
    for name in report.status.keys() {
        assert!(html.contains(&format!("<td>{name}</td>")), "node {name} in the table");
    }
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"), "nothing from a network");

    let Some(browser) = chromium() else {
        return common::skip("HDRFLOW_REQUIRE_CHROMIUM", "the headless-browser check of the HTML report: no chromium");
    };
    let dom = headless(browser, &page, &["--dump-dom"]);
    dom.assert_success();
    let loaded = body_attr(&dom.stdout, "data-images").unwrap_or_else(|| panic!("no data-images\n{}", dom.describe()));
    assert_eq!(loaded, format!("{images}/{images}"), "every thumbnail decoded in the browser");
    let drawn = body_attr(&dom.stdout, "data-graph-nodes").expect("data-graph-nodes");
    let n = report.status.len();
    assert_eq!(drawn, format!("{n}/{n}"), "every node's name drawn in the graph");

    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("html-report.png");
    let _ = std::fs::remove_file(&shot);
    headless(browser, &page, &["--window-size=1280,2000", &format!("--screenshot={}", shot.display())])
        .assert_success();
    let png = std::fs::read(&shot).expect("a screenshot");
    assert!(png.starts_with(b"\x89PNG") && png.len() > 20_000, "{} bytes", png.len());
    eprintln!("screenshot of the report: {}", shot.display());
}

#[test]
fn a_failed_run_still_writes_its_page_with_the_error() {
    let sb = Sandbox::new();
    sb.write("bad.pfm", b"PF\n4 4\n-1.0\ntruncated");
    let g =
        sb.write("g.ron", r#"( nodes: { "env": LoadHdr(path: "bad.pfm"), "s": Save(input: "env", path: "e.pfm") } )"#);
    let page = sb.join("r.html");
    let (out, _) = sb.run(&g, &["--html", page.to_str().unwrap()]);
    out.assert_code(1);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("id=\"error\"") && html.contains("bad.pfm"), "{html}");
    assert!(html.contains("id=\"graph\""), "the graph is still drawn");
}
