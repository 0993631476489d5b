//! Progress on a terminal (a bar naming the nodes running now, shown once a run lasts more than
//! a moment); per-node lines off a terminal only with `-v`; and the end-of-run table (`-v`).

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::engine::scheduler::{NodeReport, NodeStatus, Observer, RunReport};

/// How long a run may last before a bar appears.
const BAR_DELAY: Duration = Duration::from_millis(300);

/// How much a run prints.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verbosity {
    /// Errors and warnings only.
    Quiet,
    /// The progress bar on a terminal and the summary line.
    Normal,
    /// Also a line per node and the per-node table.
    Verbose,
}

pub struct Progress {
    verbosity: Verbosity,
    terminal: bool,
    start: Instant,
    bar: Mutex<Option<ProgressBar>>,
    shown: std::sync::atomic::AtomicBool,
    /// The nodes running now, in start order (the bar names them).
    running: Mutex<Vec<String>>,
}

impl Progress {
    pub fn new(verbosity: Verbosity) -> Self {
        Progress {
            verbosity,
            terminal: std::io::stderr().is_terminal(),
            start: Instant::now(),
            bar: Mutex::new(None),
            shown: std::sync::atomic::AtomicBool::new(false),
            running: Mutex::new(Vec::new()),
        }
    }

    fn running_message(&self) -> String {
        let running = self.running.lock().expect("progress lock");
        match running.len() {
            0 => String::new(),
            1..=3 => running.join(", "),
            n => format!("{} and {} more", running[..3].join(", "), n - 3),
        }
    }

    fn with_bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Some(bar) = self.bar.lock().expect("progress lock").as_ref() {
            if !self.shown.load(std::sync::atomic::Ordering::Relaxed) && self.start.elapsed() > BAR_DELAY {
                bar.set_draw_target(ProgressDrawTarget::stderr());
                bar.enable_steady_tick(Duration::from_millis(100));
                self.shown.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            f(bar);
        }
    }

    pub fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }
}

impl Observer for Progress {
    fn planned(&self, compute: usize, _cached: usize) {
        if self.verbosity == Verbosity::Quiet || !self.terminal {
            return;
        }
        let bar = ProgressBar::with_draw_target(Some(compute as u64), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} nodes  running: {msg}")
                .expect("valid template"),
        );
        *self.bar.lock().expect("progress lock") = Some(bar);
    }

    fn node_started(&self, name: &str) {
        self.running.lock().expect("progress lock").push(name.to_string());
        let message = self.running_message();
        self.with_bar(|b| b.set_message(message));
    }

    fn node_finished(&self, r: &NodeReport) {
        self.running.lock().expect("progress lock").retain(|n| n != &r.name);
        if self.verbosity == Verbosity::Quiet {
            return;
        }
        if self.terminal {
            if r.status == NodeStatus::Computed {
                let message = self.running_message();
                self.with_bar(|b| {
                    b.inc(1);
                    b.set_message(message);
                });
            }
        } else if r.status == NodeStatus::Computed && self.verbosity == Verbosity::Verbose {
            eprintln!(
                "[{:>8.1} ms] computed {} ({}) in {:.1} ms",
                self.start.elapsed().as_secs_f64() * 1e3,
                r.name,
                r.op,
                r.ms
            );
        }
    }

    fn warning(&self, message: &str) {
        let line = format!("warning: {message}");
        match self.bar.lock().expect("progress lock").as_ref() {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        }
    }
}

/// The per-node table printed at the end of a run.
pub fn print_table(report: &RunReport) {
    outln!("{:<24} {:<18} {:<10} {:>10}", "node", "operator", "status", "ms");
    for n in &report.nodes {
        outln!("{:<24} {:<18} {:<10} {:>10.2}", n.name, n.op, n.status.word(), n.ms);
    }
}
