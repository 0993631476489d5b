//! `hdrflow watch`: reruns on a save-by-rename of the pipeline and on an in-place write of a map it
//! reads, recomputing only what changed; survives a broken pipeline; ends cleanly on SIGINT.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use common::*;

const GRAPH: &str = r#"( nodes: {
  "env":   LoadHdr(path: "m.pfm"),
  "e":     Exposure(image: "env", stops: STOPS),
  "s":     Save(input: "e", path: "e.pfm"),
  "flat":  Constant(width: 8, height: 4, color: 0.5),
  "s_flat": Save(input: "flat", path: "flat.pfm"),
} )"#;

struct Watch {
    child: Child,
    lines: Receiver<String>,
    stderr: Receiver<String>,
}

impl Watch {
    /// Waits for the summary line of run `n`; returns it and how long it took. Any other line
    /// (a rerun nobody asked for) fails the test.
    fn run_line(&self, n: usize) -> (String, Duration) {
        let start = Instant::now();
        let needle = format!("run {n}");
        match self.lines.recv_timeout(Duration::from_secs(60)) {
            Ok(l) if l.contains(&format!("{needle}:")) || l.contains(&format!("{needle} (")) => (l, start.elapsed()),
            Ok(l) => panic!("expected run {n}, got: {l}"),
            Err(e) => {
                let err: Vec<String> = self.stderr.try_iter().collect();
                panic!("no summary line of run {n} ({e}); stderr:\n{}", err.join("\n"))
            }
        }
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn lines_of(pipe: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

fn start(sb: &Sandbox) -> Watch {
    let mut cmd = Command::new(BIN);
    cmd.args(["watch", "g.ron", "--out", "out", "--cache-dir", "cache", "--report", "r.json"])
        .args(["--html", "report.html", "--debounce-ms", "100"])
        .current_dir(sb.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("hdrflow watch starts");
    let lines = lines_of(child.stdout.take().unwrap());
    let stderr = lines_of(child.stderr.take().unwrap());
    Watch { child, lines, stderr }
}

/// Saves like an editor that writes a temporary file and renames it over the original.
fn save_by_rename(sb: &Sandbox, name: &str, text: &str) {
    let tmp = sb.join(format!(".{name}.swp"));
    std::fs::write(&tmp, text).unwrap();
    std::fs::rename(&tmp, sb.join(name)).unwrap();
}

#[test]
fn reruns_only_what_changed_survives_errors_and_stops_on_sigint() {
    let sb = Sandbox::new();
    sb.write("m.pfm", small_pfm(16, 8, 1.0));
    sb.write("g.ron", GRAPH.replace("STOPS", "0"));
    let w = start(&sb);
    let (first, _) = w.run_line(1);
    assert!(first.contains("5 computed"), "{first}");
    let html = std::fs::read_to_string(sb.join("report.html")).unwrap();
    assert!(html.contains("http-equiv=\"refresh\""), "the watch page reloads itself");

    // Save-by-rename of the pipeline: only the exposure and its save rerun.
    save_by_rename(&sb, "g.ron", &GRAPH.replace("STOPS", "1"));
    let (second, latency) = w.run_line(2);
    assert!(second.contains("(g.ron changed)"), "{second}");
    let r = read_report(&sb.join("r.json"));
    assert_eq!(r.status_of("e"), "computed");
    assert_eq!(r.status_of("s"), "computed");
    assert_eq!(r.status_of("env"), "cached");
    assert_eq!(r.status_of("s_flat"), "cached");
    eprintln!("watch latency, save to summary line: {latency:.2?} (debounce 100 ms)");

    // An in-place write of the map it reads.
    std::fs::write(sb.join("m.pfm"), small_pfm(16, 8, 2.0)).unwrap();
    let (third, _) = w.run_line(3);
    assert!(third.contains("(m.pfm changed)"), "{third}");
    assert_eq!(read_report(&sb.join("r.json")).status_of("env"), "computed");

    // A broken pipeline: the error with its position, and the watch goes on.
    save_by_rename(&sb, "g.ron", &GRAPH.replace("STOPS", "1").replace("\"s\":", "\"s\""));
    let (fourth, _) = w.run_line(4);
    assert!(fourth.contains("errors"), "{fourth}");
    let html = std::fs::read_to_string(sb.join("report.html")).unwrap();
    assert!(html.contains("id=\"error\"") && html.contains("g.ron:"), "the page shows the error");
    save_by_rename(&sb, "g.ron", &GRAPH.replace("STOPS", "2"));
    let (fifth, _) = w.run_line(5);
    assert!(fifth.contains("computed"), "{fifth}");
    let err: String = w.stderr.try_iter().collect::<Vec<_>>().join("\n");
    assert!(err.contains("g.ron:4:"), "the error names file, line and column:\n{err}");

    // Ctrl-C ends it cleanly.
    let pid = w.child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let mut w = w;
    let start = Instant::now();
    let status = loop {
        if let Some(s) = w.child.try_wait().unwrap() {
            break s;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "watch did not stop on SIGINT");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(0));
    let err: String = w.stderr.iter().collect::<Vec<_>>().join("\n");
    assert!(err.contains("watch: stopped after 5 runs"), "{err}");
}

#[test]
fn options_for_a_single_run_are_refused() {
    for flag in [&["--json"][..], &["--print", "s"], &["-v"]] {
        let mut args = vec!["watch", "g.ron"];
        args.extend_from_slice(flag);
        run_hdrflow(&args).assert_code(2).assert_stderr_contains("one summary line per run");
    }
}
