//! A loopback HTTP/1.1 server for a web client's render page (`web_page.rs`), standard library
//! only: `GET /app/PATH` serves the client's folder (`clients/filament-web/PATH`,
//! `clients/three-web/PATH`: the page, its scripts, node_modules), `GET /common/PATH` the clients'
//! shared folder (`clients/web-common`), `GET /work/PATH` a file of the test's folder (job.json,
//! the bakes), `POST /result/NAME` writes the body to
//! `RESULTS/NAME`. One request per connection (`Connection: close`), bodies up to 64 MiB, paths
//! without `..`; it listens on 127.0.0.1 only, on a port the system picks, and stops when
//! dropped.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

const MAX_BODY: usize = 64 << 20;

pub struct Server {
    pub port: u16,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

struct Roots {
    app: PathBuf,
    common: PathBuf,
    work: PathBuf,
    results: PathBuf,
}

impl Server {
    pub fn start(app: &Path, common: &Path, work: &Path, results: &Path) -> Server {
        std::fs::create_dir_all(results).expect("the results folder");
        let listener = TcpListener::bind("127.0.0.1:0").expect("a loopback port");
        let port = listener.local_addr().expect("its address").port();
        let stop = Arc::new(AtomicBool::new(false));
        let roots = Arc::new(Roots {
            app: app.to_path_buf(),
            common: common.to_path_buf(),
            work: work.to_path_buf(),
            results: results.to_path_buf(),
        });
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            for stream in listener.incoming() {
                if flag.load(Ordering::SeqCst) {
                    break;
                }
                if let Ok(stream) = stream {
                    let roots = roots.clone();
                    std::thread::spawn(move || {
                        let _ = serve(stream, &roots);
                    });
                }
            }
        });
        Server { port, stop, thread: Some(thread) }
    }

    pub fn url(&self, path: &str) -> String {
        format!("http://127.0.0.1:{}/{path}", self.port)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wake the accept loop so it sees the flag.
        let _ = TcpStream::connect(("127.0.0.1", self.port));
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()) {
        Some("html") => "text/html; charset=utf-8",
        Some("js" | "mjs") => "text/javascript",
        Some("wasm") => "application/wasm",
        Some("json") => "application/json",
        Some("txt") => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

/// `root/rel` when `rel` stays inside `root`.
fn inside(root: &Path, rel: &str) -> Option<PathBuf> {
    let rel = rel.split(['?', '#']).next().unwrap_or("");
    if rel.is_empty() || rel.split('/').any(|p| p == ".." || p.contains('\\')) {
        return None;
    }
    Some(root.join(rel))
}

fn respond(stream: &mut TcpStream, status: &str, kind: &str, body: &[u8]) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()?;
    stream.shutdown(Shutdown::Write)
}

fn serve(mut stream: TcpStream, roots: &Roots) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(60)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("").to_string());
    let mut length = 0usize;
    loop {
        let mut header = String::new();
        if reader.read_line(&mut header)? == 0 || header.trim().is_empty() {
            break;
        }
        if let Some((k, v)) = header.split_once(':') {
            if k.trim().eq_ignore_ascii_case("content-length") {
                length = v.trim().parse().unwrap_or(0);
            }
        }
    }
    match method {
        "GET" => {
            let file = if let Some(rel) = target.strip_prefix("/app/") {
                inside(&roots.app, rel)
            } else if let Some(rel) = target.strip_prefix("/common/") {
                inside(&roots.common, rel)
            } else if let Some(rel) = target.strip_prefix("/work/") {
                inside(&roots.work, rel)
            } else {
                None
            };
            match file.and_then(|f| std::fs::read(&f).ok().map(|b| (f, b))) {
                Some((f, bytes)) => respond(&mut stream, "200 OK", content_type(&f), &bytes),
                None => respond(&mut stream, "404 Not Found", "text/plain", b"not found"),
            }
        }
        "POST" if length <= MAX_BODY => {
            let mut body = vec![0u8; length];
            reader.read_exact(&mut body)?;
            match target.strip_prefix("/result/").and_then(|rel| inside(&roots.results, rel)) {
                Some(f) if !rel_has_slash(&target) => {
                    std::fs::write(&f, &body)?;
                    respond(&mut stream, "200 OK", "text/plain", b"ok")
                }
                _ => respond(&mut stream, "404 Not Found", "text/plain", b"not found"),
            }
        }
        _ => respond(&mut stream, "400 Bad Request", "text/plain", b"bad request"),
    }
}

/// Results are plain file names.
fn rel_has_slash(target: &str) -> bool {
    target.strip_prefix("/result/").is_some_and(|r| r.contains('/'))
}
