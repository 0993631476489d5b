//! A web client's render page run by an engine render test (tests/filament_render.rs,
//! tests/three_render.rs): the test writes a job, serves the client's folder and its own on
//! loopback (`server.rs`), opens the page in headless Chromium, and reads back what the page
//! posted: `report.json` and the frames as raw 32-bit floats. Included by `#[path]`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use hdrflow::values::Image;
use serde_json::Value as Json;

use crate::common;

#[path = "server.rs"]
mod server;

/// Chromium, or `None` after a visible skip (a failure under `require=1`) when it or one of the
/// client's installed `files` (relative to `app/node_modules`) is missing; `install` says how to
/// install them.
pub fn browser(require: &str, app: &Path, files: &[&str], install: &str) -> Option<&'static str> {
    let Some(browser) = ["chromium", "chromium-browser", "google-chrome"].into_iter().find(|c| {
        Command::new("sh").arg("-c").arg(format!("command -v {c}")).output().is_ok_and(|o| o.status.success())
    }) else {
        common::skip(require, "no chromium (apt-get install chromium)");
        return None;
    };
    let modules = app.join("node_modules");
    if let Some(missing) = files.iter().map(|f| modules.join(f)).find(|f| !f.is_file()) {
        common::skip(require, &format!("no {}: install the client's npm packages with {install}", missing.display()));
        return None;
    }
    Some(browser)
}

/// What the page reported, and where its results are.
pub struct Page {
    pub report: Json,
    pub results: PathBuf,
}

/// Serves `job` (paths relative to the sandbox), the client folder `app` and the clients' shared
/// `clients/web-common` to the page `app/index.html` in headless Chromium, waits for its report (at most `timeout`), fails on any
/// error the page reports, and keeps the results in `target/tmp/KEEP` (RGBA f32 rows, top first).
#[allow(dead_code)] // tests/playcanvas_render.rs calls run_with_budget only
pub fn run(browser: &str, app: &Path, sandbox: &common::Sandbox, job: &Json, keep: &str, timeout: Duration) -> Page {
    run_with_budget(browser, app, sandbox, job, keep, timeout, 86_400_000)
}

/// [`run`] with Chromium's virtual-time budget `budget_ms` (a day for [`run`]): virtual time runs
/// ahead of the wall clock while the page computes without yielding or polls with timers
/// (PlayCanvas' skybox filter took 20-30 s of SwiftShader time, up to 1700 s of virtual time;
/// Babylon's `CreateEnvTextureAsync` readbacks spent an hour in 35 s), and the page is dumped when
/// the budget is spent.
pub fn run_with_budget(
    browser: &str,
    app: &Path,
    sandbox: &common::Sandbox,
    job: &Json,
    keep: &str,
    timeout: Duration,
    budget_ms: u64,
) -> Page {
    std::fs::write(sandbox.join("job.json"), serde_json::to_vec_pretty(job).expect("the job as JSON"))
        .expect("writing job.json");
    let results = sandbox.join("results");
    let _ = std::fs::remove_dir_all(&results);
    let shared = Path::new(common::MANIFEST_DIR).join("clients/web-common");
    let server = server::Server::start(app, &shared, sandbox.path(), &results);
    let profile = sandbox.join("chromium-profile");
    let _ = std::fs::remove_dir_all(&profile);
    let mut cmd = Command::new(browser);
    // --no-sandbox: CI runs as root. No network of its own, a fresh profile. SwiftShader: the
    // same CPU WebGL2 everywhere. Virtual time: the page's timers run as fast as the work allows;
    // the dump waits for the budget or the end.
    cmd.args(["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run"])
        .args(["--disable-background-networking", "--disable-component-update", "--disable-sync"])
        .args(["--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        .args(["--enable-logging=stderr", "--v=0", &format!("--virtual-time-budget={budget_ms}"), "--dump-dom"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(server.url("app/index.html"));
    let out = common::run_command(cmd, timeout);
    drop(server);
    let console: Vec<&str> = out.stderr.lines().filter(|l| l.contains(":CONSOLE")).collect();
    let report: Json = match std::fs::read(results.join("report.json")) {
        Ok(bytes) => serde_json::from_slice(&bytes).expect("the page's report is JSON"),
        Err(_) => panic!("the page wrote no report\nconsole:\n{}\n{}", console.join("\n"), out.describe()),
    };
    assert!(report.get("fatal").is_none(), "the page failed: {report}\nconsole:\n{}", console.join("\n"));
    let errors = report["errors"].as_array().map(Vec::len).unwrap_or(0);
    assert_eq!(errors, 0, "the page reported errors: {}\nconsole:\n{}", report["errors"], console.join("\n"));
    assert!(out.stdout.contains("data-status=\"done\""), "the page did not finish\n{}", out.describe());
    let kept = Path::new(env!("CARGO_TARGET_TMPDIR")).join(keep);
    let _ = std::fs::remove_dir_all(&kept);
    std::fs::create_dir_all(&kept).expect("the artefact folder");
    for entry in std::fs::read_dir(&results).expect("the results").flatten() {
        let _ = std::fs::copy(entry.path(), kept.join(entry.file_name()));
    }
    eprintln!(
        "browser: {} renders in {:.1} s ({}); frames kept in {}",
        job["renders"].as_array().map(Vec::len).unwrap_or(0),
        out.elapsed.as_secs_f64(),
        report["webgl"],
        kept.display()
    );
    Page { report, results }
}

impl Page {
    /// Render `name` as a `width` x `height` RGBA image.
    pub fn frame(&self, name: &str, width: usize, height: usize) -> Image {
        let bytes = common::read_file(&self.results.join(format!("{name}.f32")));
        assert_eq!(bytes.len(), width * height * 16, "{name}: {} bytes", bytes.len());
        let mut img = Image::new(width, height, 4);
        img.data = bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        img
    }

    /// The page's report of render `name`.
    pub fn render_report(&self, name: &str) -> &Json {
        self.report["renders"]
            .as_array()
            .and_then(|r| r.iter().find(|e| e["name"] == name))
            .unwrap_or_else(|| panic!("no render {name} in {}", self.report))
    }
}

/// `hdrflow bake MAP --for ENGINE --sun keep --out SANDBOX/DIR -q` plus `extra`, into the sandbox's
/// cache; the bake's folder.
#[allow(dead_code)] // not every render test bakes with the sun kept
pub fn bake(sandbox: &common::Sandbox, map: &Path, engine: &str, dir: &str, extra: &[&str]) -> PathBuf {
    bake_with_sun(sandbox, map, engine, dir, "keep", extra)
}

/// [`bake`] with `--sun SUN` (`keep` or `extract`).
#[allow(dead_code)]
pub fn bake_with_sun(
    sandbox: &common::Sandbox,
    map: &Path,
    engine: &str,
    dir: &str,
    sun: &str,
    extra: &[&str],
) -> PathBuf {
    let out = sandbox.join(dir);
    let cache = sandbox.cache();
    let mut args = vec!["bake", map.to_str().expect("UTF-8 paths"), "--for", engine, "--sun", sun];
    args.extend_from_slice(&["--out", out.to_str().expect("UTF-8"), "--cache-dir", cache.to_str().expect("UTF-8")]);
    args.push("-q");
    args.extend_from_slice(extra);
    common::run_hdrflow(args).assert_success();
    out
}

/// `img` written as a PFM map named `name` in the sandbox.
#[allow(dead_code)] // not every render test writes maps
pub fn write_map(sandbox: &common::Sandbox, name: &str, img: &Image) -> PathBuf {
    sandbox.write(name, hdrflow::formats::pfm::encode(img))
}

/// `p` relative to the sandbox, as the page's job names files.
#[allow(dead_code)]
pub fn rel(sandbox: &common::Sandbox, p: &Path) -> String {
    p.strip_prefix(sandbox.path()).expect("inside the sandbox").to_str().expect("UTF-8").to_string()
}
