//! Step 6 of a run (see the module doc of `scheduler`): the output folder, checked before
//! anything is computed, and files written into it atomically when their bytes changed.

use std::path::{Path, PathBuf};

use crate::engine::cache::store::{remove_stale_temporaries, write_atomic};
use crate::engine::error::RunError;

/// Makes sure `dir` can receive output files: created if missing, a folder, writable.
pub fn check_output_dir(dir: &Path) -> Result<(), RunError> {
    let fail = |reason: String| RunError::OutputDir { path: dir.to_path_buf(), reason };
    if dir.exists() && !dir.is_dir() {
        return Err(fail("it exists and is not a folder".into()));
    }
    std::fs::create_dir_all(dir).map_err(|e| fail(format!("cannot create it: {e}")))?;
    let probe = dir.join(format!(".hdrflow-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(|e| fail(format!("cannot write into it: {e}")))?;
    let _ = std::fs::remove_file(&probe);
    // A run killed between the write and the removal leaves its probe: remove any such leftover
    // (another live run's probe may go too, which is harmless: it has already been written).
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(".hdrflow-write-test-") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    Ok(())
}

/// Writes one output file unless identical bytes are already there. Returns the path if written.
pub(super) fn write_output(out_dir: &Path, rel: &str, bytes: &[u8]) -> Result<Option<PathBuf>, RunError> {
    crate::engine::graph::check_output_path(rel).map_err(|_| RunError::PathEscape(rel.to_string()))?;
    let path = out_dir.join(rel);
    remove_stale_temporaries(&path);
    if let Ok(existing) = std::fs::metadata(&path) {
        if existing.len() == bytes.len() as u64 && std::fs::read(&path).map(|b| b == bytes).unwrap_or(false) {
            return Ok(None);
        }
    }
    write_atomic(&path, bytes).map_err(|source| RunError::Output { path: path.clone(), source })?;
    Ok(Some(path))
}
