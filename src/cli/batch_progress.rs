//! `hdrflow batch`'s progress report (`BatchObserver`): the bar through the shared phase and the
//! items, or one line per item off a terminal.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

use crate::batch::{BatchObserver, Item, ItemRow, ItemStatus};

/// The bar while items run.
pub(super) fn items_style() -> ProgressStyle {
    ProgressStyle::with_template("{bar:30} {pos}/{len} items, {msg} [{elapsed_precise}, eta {eta}]").expect("template")
}

/// The bar during the shared phase: no item has finished, so no item count or eta yet.
pub(super) fn shared_style() -> ProgressStyle {
    ProgressStyle::with_template("{spinner} {msg} [{elapsed_precise}]").expect("template")
}

/// `hdrflow batch`'s progress: a bar on a terminal (the shared phase, then the items), one line
/// per item elsewhere.
pub(super) struct Progress {
    pub(super) total: usize,
    pub(super) quiet: bool,
    pub(super) bar: Option<ProgressBar>,
    pub(super) counts: Mutex<[usize; 3]>,
    pub(super) start: Instant,
    /// The bar shows the shared phase.
    pub(super) sharing: AtomicBool,
}

impl Progress {
    /// Back to the item bar after the shared phase (once).
    fn items_phase(&self, bar: &ProgressBar) {
        if self.sharing.swap(false, Ordering::SeqCst) {
            bar.disable_steady_tick();
            bar.set_style(items_style());
            bar.set_message(self.message());
        }
    }
    pub(super) fn message(&self) -> String {
        let c = self.counts.lock().expect("progress lock");
        let done = c[0] + c[1] + c[2];
        format!("{} computed, {} cached, {} failed, {} left", c[0], c[1], c[2], self.total - done)
    }
}

impl BatchObserver for Progress {
    fn shared_phase(&self, nodes: usize) {
        if let Some(bar) = &self.bar {
            self.sharing.store(true, Ordering::SeqCst);
            bar.set_style(shared_style());
            bar.set_message(format!("shared nodes 0/{nodes} (computed once for several items)"));
            bar.enable_steady_tick(std::time::Duration::from_millis(200));
        } else if !self.quiet {
            eprintln!("shared: {nodes} nodes used by several items, computed once first");
        }
    }
    fn shared_progress(&self, done: usize, total: usize) {
        // Off a terminal one line per shared node would drown the item lines: the first line
        // and the summary give the count.
        if let Some(bar) = &self.bar {
            bar.set_message(format!("shared nodes {done}/{total} (computed once for several items)"));
            if done == total {
                self.items_phase(bar);
            }
        }
    }
    fn item_started(&self, _item: &Item) {
        // A failed shared job leaves the count short of its total.
        if let Some(bar) = &self.bar {
            self.items_phase(bar);
        }
    }
    fn item_finished(&self, row: &ItemRow) {
        {
            let mut c = self.counts.lock().expect("progress lock");
            c[match row.status {
                ItemStatus::Computed => 0,
                ItemStatus::Cached => 1,
                ItemStatus::Failed => 2,
            }] += 1;
        }
        if let Some(bar) = &self.bar {
            if let Some(e) = &row.error {
                bar.println(format!("failed: {}: {e}", row.item.dir));
            }
            bar.inc(1);
            bar.set_message(self.message());
        } else if !self.quiet || row.error.is_some() {
            let done: usize = self.counts.lock().expect("progress lock").iter().sum();
            let err = row.error.as_ref().map(|e| format!(": {e}")).unwrap_or_default();
            eprintln!("[{done}/{}] {} {} {:.1} ms{err}", self.total, row.item.dir, row.status.word(), row.ms);
        }
    }
}
