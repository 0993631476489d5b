//! Leases and eviction: each run's lease file (`<dir>/v1/live/<pid>-<n>@<host>`), the oldest
//! live lease that spares the entries used since, and least-recently-used pruning down to a size
//! (see the [parent module](super) for the policy). Kept apart from reading and writing entries,
//! which never need it.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::SystemTime;

use super::{default_max_bytes, key_of_entry, CacheStore, TMP_COUNTER};
use crate::engine::cache::key::Key;
use crate::engine::error::CacheError;

/// A live run's claim on the entries it uses: while it exists, `prune` spares every entry used
/// since it was taken. Dropping it releases the claim.
#[derive(Debug)]
pub struct Lease {
    path: PathBuf,
}

impl Drop for Lease {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

/// What eviction did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EvictionReport {
    pub entries: usize,
    pub bytes_before: u64,
    pub removed: usize,
    pub bytes_after: u64,
}

impl CacheStore {
    /// Takes a lease for a run (see the module documentation).
    pub fn lease(&self) -> Result<Lease, CacheError> {
        let dir = self.root.join("live");
        fs::create_dir_all(&dir).map_err(|source| CacheError::Io { path: dir.clone(), source })?;
        let path =
            dir.join(format!("{}-{}@{}", std::process::id(), TMP_COUNTER.fetch_add(1, Ordering::Relaxed), this_host()));
        fs::write(&path, b"").map_err(|source| CacheError::Io { path: path.clone(), source })?;
        Ok(Lease { path })
    }

    /// The start of the oldest live run, if any; leases of processes that are gone are removed.
    pub(super) fn oldest_live_lease(&self) -> (Option<SystemTime>, usize) {
        let Ok(entries) = fs::read_dir(self.root.join("live")) else { return (None, 0) };
        let proc_fs = Path::new("/proc/self").exists();
        let mut oldest: Option<SystemTime> = None;
        let mut live = 0;
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            // `PID-N@HOST`: only this host's processes can be checked (on a shared filesystem,
            // another node's lease is live as far as this node can tell).
            let (local, host) = name.split_once('@').unwrap_or((name.as_str(), ""));
            let pid = local.split('-').next().and_then(|p| p.parse::<u32>().ok());
            let dead = match pid {
                Some(pid) if proc_fs && host == this_host() => {
                    pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists()
                }
                // Another node's lease is trusted for a day: a node that died mid-run must not
                // pin the shared folder for ever.
                _ if !host.is_empty() && host != this_host() => e
                    .metadata()
                    .and_then(|m| m.modified())
                    .ok()
                    .and_then(|t| t.elapsed().ok())
                    .is_some_and(|age| age.as_secs() > FOREIGN_LEASE_SECS),
                _ => false,
            };
            if dead {
                let _ = fs::remove_file(e.path());
                continue;
            }
            live += 1;
            if let Ok(t) = e.metadata().and_then(|m| m.modified()) {
                oldest = Some(oldest.map_or(t, |o| o.min(t)));
            }
        }
        (oldest, live)
    }

    /// Removes least-recently-used entries until the folder holds at most `max_bytes`, sparing
    /// entries used since the start of a live run (see the module documentation).
    pub fn prune(&self, max_bytes: u64) -> Result<EvictionReport, CacheError> {
        self.prune_sparing(max_bytes, &|_| false)
    }

    /// [`prune`](Self::prune) that also spares the entries whose key `spare` accepts (a batch
    /// pins the shared entries its remaining items will load).
    pub fn prune_sparing(&self, max_bytes: u64, spare: &dyn Fn(&Key) -> bool) -> Result<EvictionReport, CacheError> {
        let (oldest_live, _) = self.oldest_live_lease();
        let mut entries: Vec<(SystemTime, u64, PathBuf)> = Vec::new();
        for (mtime, len, path) in self.entries()? {
            // Temporary files older than an hour were left by a killed run.
            if path.to_string_lossy().contains(".tmp-") {
                if mtime.elapsed().map(|e| e.as_secs() > 3600).unwrap_or(false) {
                    let _ = fs::remove_file(&path);
                }
                continue;
            }
            entries.push((mtime, len, path));
        }
        let bytes_before: u64 = entries.iter().map(|e| e.1).sum();
        let mut report = EvictionReport { entries: entries.len(), bytes_before, removed: 0, bytes_after: bytes_before };
        if bytes_before <= max_bytes {
            return Ok(report);
        }
        entries.sort_by_key(|e| e.0);
        for (mtime, len, path) in entries {
            if report.bytes_after <= max_bytes {
                break;
            }
            if oldest_live.is_some_and(|start| mtime >= start) {
                continue; // in use by a live run
            }
            if key_of_entry(&path).is_some_and(|k| spare(&k)) {
                continue;
            }
            if fs::remove_file(&path).is_ok() {
                report.removed += 1;
                report.bytes_after -= len;
            }
        }
        Ok(report)
    }

    /// Removes least-recently-used entries until the store is under the default size
    /// (`default_max_bytes`), sparing entries in use by live runs.
    pub fn evict(&self) -> Result<EvictionReport, CacheError> {
        self.prune(default_max_bytes())
    }
}

/// How long a lease of another machine counts as live: one day.
pub(super) const FOREIGN_LEASE_SECS: u64 = 24 * 3600;

/// This machine's name (Linux), for lease files on a shared cache folder; empty elsewhere.
pub(super) fn this_host() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        fs::read_to_string("/proc/sys/kernel/hostname")
            .map(|h| h.trim().chars().filter(|c| c.is_ascii_alphanumeric() || "-._".contains(*c)).collect())
            .unwrap_or_default()
    })
}
