//! The on-disk store: `<dir>/v1/<first two hex digits>/<key hex>.val`.
//!
//! Entry layout: magic `HDRFLOWC`, codec version (u32), payload length (u64), BLAKE3 of the
//! payload (32 bytes), payload. An entry is written to a temporary file in its final folder and
//! renamed into place, so readers see a whole entry or none, and two runs writing the same key
//! at once both succeed (the last rename wins; both wrote the same bytes). A read checks magic,
//! version, length and checksum: anything else is reported as corrupt and recomputed.
//! Reads refresh the entry's modification time, which is what eviction orders by (LRU).
//!
//! Size: a run may add at most `add_limit_bytes` (`--cache-limit-mb`); past that its results are
//! not stored. The folder as a whole is pruned least-recently-used first down to a size
//! (`prune`, `hdrflow cache prune`, and after every run to the default 4 GiB or
//! `$HDRFLOW_CACHE_MAX_MB`), but an entry used since the start of a live run is never removed:
//! each run holds a lease file `<dir>/v1/live/<pid>-<n>@<host>` for its duration, and entries whose
//! time is newer than the oldest live lease are spared. On a folder that several machines share,
//! another machine's lease counts as live for a day. Leases of processes that are gone are
//! removed. So one run's limit never empties a cache that other pipelines share.
//!
//! Files: this one reads and writes entries; `eviction` holds the leases and the pruning.

mod eviction;
#[cfg(test)]
mod tests;

pub use eviction::{EvictionReport, Lease};

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::SystemTime;

use super::codec::{self, CODEC_VERSION};
use super::key::{key_hex, Key};
use super::policy::PersistPolicy;
use crate::engine::error::CacheError;
use crate::engine::registry::Registry;
use crate::engine::value::Value;

const MAGIC: &[u8; 8] = b"HDRFLOWC";
const HEADER_LEN: usize = 8 + 4 + 8 + 32;

/// Default size of the cache folder that runs prune down to: 4 GiB (`$HDRFLOW_CACHE_MAX_MB`
/// overrides it).
pub const DEFAULT_LIMIT_BYTES: u64 = 4 << 30;

/// The folder size runs prune down to: `$HDRFLOW_CACHE_MAX_MB` MiB, else 4 GiB.
pub fn default_max_bytes() -> u64 {
    std::env::var("HDRFLOW_CACHE_MAX_MB")
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .map_or(DEFAULT_LIMIT_BYTES, |mb| mb << 20)
}

#[derive(Debug, Clone)]
pub struct CacheStore {
    root: PathBuf,
    /// How many bytes this store handle may add (one run's `--cache-limit-mb`).
    add_limit_bytes: u64,
    /// Bytes added through this handle (and its clones).
    added: std::sync::Arc<AtomicU64>,
    /// Which computed results runs through this handle store.
    policy: PersistPolicy,
}

/// What the cache folder holds (`hdrflow cache stats`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CacheStats {
    pub entries: usize,
    pub bytes: u64,
    /// Live runs holding a lease.
    pub live_runs: usize,
    /// Temporary files left by killed runs.
    pub temporaries: usize,
}

impl CacheStore {
    /// A store under `dir` (created on first write) through which at most `add_limit_bytes`
    /// may be added.
    pub fn new(dir: impl Into<PathBuf>, add_limit_bytes: u64) -> Self {
        CacheStore {
            root: dir.into().join("v1"),
            add_limit_bytes,
            added: Default::default(),
            policy: PersistPolicy::default(),
        }
    }

    /// The same store with another persistence policy.
    pub fn with_policy(mut self, policy: PersistPolicy) -> Self {
        self.policy = policy;
        self
    }

    pub fn policy(&self) -> PersistPolicy {
        self.policy
    }

    /// The same store with another add limit.
    pub fn with_add_limit(mut self, bytes: u64) -> Self {
        self.add_limit_bytes = bytes;
        self
    }

    /// A handle on the same folder whose add limit counts from zero again (one per batch item).
    pub fn fork(&self) -> Self {
        CacheStore { added: Default::default(), ..self.clone() }
    }

    /// Bytes added through this handle so far.
    pub fn added_bytes(&self) -> u64 {
        self.added.load(Ordering::Relaxed)
    }

    /// The per-user default folder: `$HDRFLOW_CACHE_DIR`, else `$XDG_CACHE_HOME/hdrflow`,
    /// else `$HOME/.cache/hdrflow`, else `.hdrflow-cache` in the working folder.
    pub fn default_dir() -> PathBuf {
        if let Some(d) = std::env::var_os("HDRFLOW_CACHE_DIR").filter(|d| !d.is_empty()) {
            return PathBuf::from(d);
        }
        if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
            return PathBuf::from(d).join("hdrflow");
        }
        if let Some(h) = std::env::var_os("HOME").filter(|d| !d.is_empty()) {
            return PathBuf::from(h).join(".cache").join("hdrflow");
        }
        PathBuf::from(".hdrflow-cache")
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    pub fn path_for(&self, key: &Key) -> PathBuf {
        let hex = key_hex(key);
        self.root.join(&hex[..2]).join(format!("{hex}.val"))
    }

    /// Whether an entry for `key` exists and its header is intact: magic, codec version, and a
    /// payload length that matches the file's size. Reads 52 bytes, so planning stays cheap; a
    /// flipped bit inside the payload is caught by the checksum when the entry is loaded.
    pub fn contains(&self, key: &Key) -> bool {
        use std::io::Read;
        let Ok(mut f) = fs::File::open(self.path_for(key)) else { return false };
        let Ok(meta) = f.metadata() else { return false };
        let mut header = [0u8; HEADER_LEN];
        if f.read_exact(&mut header).is_err() || &header[..8] != MAGIC {
            return false;
        }
        let version = u32::from_le_bytes(header[8..12].try_into().expect("4 bytes"));
        let len = u64::from_le_bytes(header[12..20].try_into().expect("8 bytes"));
        version == CODEC_VERSION && meta.len() == HEADER_LEN as u64 + len
    }

    /// Reads an entry: `Ok(None)` when absent, `Err(Corrupt)` when it cannot be trusted
    /// (the corrupt file is removed so the recomputed value can replace it).
    pub fn get(&self, key: &Key, registry: &Registry) -> Result<Option<Vec<(String, Value)>>, CacheError> {
        let path = self.path_for(key);
        let bytes = match fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(CacheError::Io { path, source }),
        };
        match check_entry(&bytes).and_then(|payload| codec::decode(payload, registry)) {
            Ok(v) => {
                // Refresh the LRU clock; failure only makes eviction less precise.
                if let Ok(f) = fs::File::options().write(true).open(&path) {
                    let _ = f.set_modified(SystemTime::now());
                }
                Ok(Some(v))
            }
            Err(reason) => {
                let _ = fs::remove_file(&path);
                Err(CacheError::Corrupt { path, reason })
            }
        }
    }

    /// Writes a node's outputs as one entry, atomically. Fails with `LimitReached` when the
    /// entry would take this handle past its add limit (nothing is written then).
    pub fn put(&self, key: &Key, outputs: &[(String, Value)]) -> Result<(), CacheError> {
        let path = self.path_for(key);
        let payload = codec::encode(outputs);
        let len = (HEADER_LEN + payload.len()) as u64;
        let before = self.added.fetch_add(len, Ordering::SeqCst);
        if before + len > self.add_limit_bytes {
            self.added.fetch_sub(len, Ordering::SeqCst);
            return Err(CacheError::LimitReached { limit_mb: self.add_limit_bytes >> 20 });
        }
        let mut entry = Vec::with_capacity(HEADER_LEN + payload.len());
        entry.extend_from_slice(MAGIC);
        entry.extend_from_slice(&CODEC_VERSION.to_le_bytes());
        entry.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        entry.extend_from_slice(blake3::hash(&payload).as_bytes());
        entry.extend_from_slice(&payload);
        // No fsync: a process kill cannot tear a renamed file, and the checksum catches what a
        // power loss might; fsync per entry cost ~1 ms a node (see docs/src/benchmarks/engine.md).
        write_atomic_with(&path, &entry, false).map_err(|source| CacheError::Io { path, source })
    }

    /// What the folder holds.
    pub fn stats(&self) -> Result<CacheStats, CacheError> {
        let mut stats = CacheStats { live_runs: self.oldest_live_lease().1, ..Default::default() };
        for (_, len, path) in self.entries()? {
            if path.to_string_lossy().contains(".tmp-") {
                stats.temporaries += 1;
            } else {
                stats.entries += 1;
                stats.bytes += len;
            }
        }
        Ok(stats)
    }

    /// Every file under the store's entry folders: (time, length, path).
    fn entries(&self) -> Result<Vec<(SystemTime, u64, PathBuf)>, CacheError> {
        let mut out = Vec::new();
        let dirs = match fs::read_dir(&self.root) {
            Ok(d) => d,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(out),
            Err(source) => return Err(CacheError::Io { path: self.root.clone(), source }),
        };
        for dir in dirs.flatten() {
            if dir.file_name() == "live" {
                continue;
            }
            let Ok(files) = fs::read_dir(dir.path()) else { continue };
            for f in files.flatten() {
                let Ok(meta) = f.metadata() else { continue };
                if meta.is_file() {
                    out.push((meta.modified().unwrap_or(SystemTime::UNIX_EPOCH), meta.len(), f.path()));
                }
            }
        }
        Ok(out)
    }

    /// Removes every entry not in use by a live run; returns what was removed.
    pub fn clear(&self) -> Result<EvictionReport, CacheError> {
        self.prune(0)
    }
}

/// The key of an entry file `<key hex>.val`.
fn key_of_entry(path: &Path) -> Option<Key> {
    let hex = path.file_name()?.to_str()?.strip_suffix(".val")?;
    if hex.len() != 64 {
        return None;
    }
    let mut key = [0u8; 32];
    for (i, byte) in key.iter_mut().enumerate() {
        *byte = u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(key)
}

fn check_entry(bytes: &[u8]) -> Result<&[u8], String> {
    if bytes.len() < HEADER_LEN {
        return Err(format!("truncated header ({} bytes)", bytes.len()));
    }
    if &bytes[..8] != MAGIC {
        return Err("bad magic".into());
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != CODEC_VERSION {
        return Err(format!("codec version {version}, expected {CODEC_VERSION}"));
    }
    let len = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    let payload = &bytes[HEADER_LEN..];
    if payload.len() as u64 != len {
        return Err(format!("payload is {} bytes, header says {len}", payload.len()));
    }
    if blake3::hash(payload).as_bytes() != &bytes[20..52] {
        return Err("checksum mismatch".into());
    }
    Ok(payload)
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically: a uniquely named temporary file in the same folder,
/// flushed to disk, then renamed over `path`. A killed process leaves at most a `.tmp-` file
/// behind, never a torn `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, bytes, true)
}

/// `write_atomic`, with the flush to disk (fsync) optional.
pub fn write_atomic_with(path: &Path, bytes: &[u8], sync: bool) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    fs::create_dir_all(dir)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let nanos = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let tmp =
        dir.join(format!(".{name}.tmp-{}-{}-{nanos}", std::process::id(), TMP_COUNTER.fetch_add(1, Ordering::Relaxed)));
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        if sync {
            f.sync_data()?;
        }
        drop(f);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Removes temporary files `.NAME.tmp-PID-...` beside `path` that a killed run left behind:
/// those whose process is gone (Linux: no `/proc/PID`) or, where that cannot be told, older
/// than an hour. A live run's temporaries are left alone.
pub fn remove_stale_temporaries(path: &Path) {
    let (Some(dir), Some(name)) = (path.parent(), path.file_name()) else { return };
    let prefix = format!(".{}.tmp-", name.to_string_lossy());
    let Ok(entries) = fs::read_dir(if dir.as_os_str().is_empty() { Path::new(".") } else { dir }) else { return };
    let proc_fs = Path::new("/proc/self").exists();
    for entry in entries.flatten() {
        let file_name = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = file_name.strip_prefix(&prefix) else { continue };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        let dead = match pid {
            Some(pid) if proc_fs => pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists(),
            _ => false,
        };
        let old = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age.as_secs() > 3600);
        if dead || old {
            let _ = fs::remove_file(entry.path());
        }
    }
}
