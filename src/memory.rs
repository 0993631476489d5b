//! Memory advice to the operating system, below every other layer (like `crate::cpu`).

/// Asks Linux to back `buf` with transparent huge pages (`madvise(MADV_HUGEPAGE)` on the whole
/// 4 KiB pages inside it; this machine's THP setting is `madvise`). A large `vec![0.0; n]` is a
/// fresh `mmap` that the kernel faults in and zeroes page by page on first write, 512 times
/// fewer faults with 2 MiB pages (the times are in docs/src/benchmarks/point-targets.md, BuildCdf). Advice only: contents are
/// unchanged, a failure is ignored, and other systems do nothing.
#[cfg(target_os = "linux")]
pub fn advise_huge_pages<T>(buf: &mut [T]) {
    const PAGE: usize = 4096;
    let bytes = std::mem::size_of_val(buf);
    if bytes < 4 << 20 {
        return; // Small buffers come from the allocator's recycled heap, already faulted in.
    }
    let start = (buf.as_mut_ptr() as usize).next_multiple_of(PAGE);
    let end = (buf.as_mut_ptr() as usize + bytes) / PAGE * PAGE;
    if end > start {
        // SAFETY: [start, end) lies inside `buf`, which this function borrows mutably, so no
        // other reference observes it; MADV_HUGEPAGE only sets how the kernel backs the pages
        // (it never discards or changes their contents, unlike MADV_DONTNEED/FREE), and the
        // call does not touch memory outside the range. The result is deliberately ignored.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
pub fn advise_huge_pages<T>(_buf: &mut [T]) {}

/// Blocks of this size and up are always mapped afresh and unmapped when freed: glibc's own
/// ceiling for its moving threshold on 64-bit systems (`DEFAULT_MMAP_THRESHOLD_MAX`), so images
/// up to 32 MiB are recycled from call to call as before.
pub const MMAP_THRESHOLD: usize = 32 << 20;

/// Fixes glibc's mmap threshold at `MMAP_THRESHOLD` for the process, which also stops the trim
/// threshold from moving (glibc's `mallopt`: setting one disables the dynamic adjustment of
/// both). By default each freed mapped block raises the mmap threshold and doubles the trim
/// threshold, so the tops of the heaps that held the JPEG decoder's buffers stay resident after
/// they are freed (docs/src/benchmarks/capture.md gives the peaks of a 24-megapixel merge either
/// way, and the bakes' times, which did not change). Called once by the CLI before any thread starts; if the user set
/// any malloc tunable in `GLIBC_TUNABLES`, theirs wins and nothing is changed; other allocators
/// and systems do nothing.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn fix_mmap_threshold() {
    if std::env::var_os("GLIBC_TUNABLES").is_some_and(|t| t.to_string_lossy().contains("glibc.malloc.")) {
        return;
    }
    // SAFETY: mallopt has no memory-safety preconditions: it sets an allocator parameter under
    // glibc's arena lock, and its one initialisation concern (malloc not yet set up) cannot arise
    // once the Rust runtime has allocated, as it has before main. A refusal (return 0) leaves
    // glibc's default, which is still correct, only larger.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD as libc::c_int);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn fix_mmap_threshold() {}

/// Reads a whole file into a buffer that the allocator maps on its own, so that freeing it returns
/// its pages to the system.
///
/// Why: a file of a few megabytes read into an ordinary `Vec` comes from a thread's heap, and once
/// freed its pages stay resident there for the rest of the run; decoding a bracket set on two
/// threads then keeps a file-sized hole per thread beside the frames (the capture benchmark's
/// peak-memory bound). A capacity of at least [`MMAP_THRESHOLD`], the largest threshold glibc
/// uses and the one [`fix_mmap_threshold`] fixes, makes the block a mapping of its own; the pages
/// past the file's end are never touched, so they cost address space, not memory.
pub fn read_file_unpooled(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut file = std::fs::File::open(path)?;
    // A size that cannot be allocated is an error, as `std::fs::read` makes it, not an abort.
    let too_large = || std::io::Error::from(std::io::ErrorKind::OutOfMemory);
    let len = usize::try_from(file.metadata()?.len()).map_err(|_| too_large())?;
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(len.saturating_add(1).max(MMAP_THRESHOLD)).map_err(|_| too_large())?;
    file.read_to_end(&mut bytes)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_page_advice_keeps_the_contents() {
        let mut fresh = vec![0.0f64; 3 << 20];
        advise_huge_pages(&mut fresh);
        assert!(fresh.iter().all(|&v| v == 0.0));
        let mut used: Vec<f64> = (0..(3usize << 20) + 5).map(|i| i as f64).collect();
        advise_huge_pages(&mut used);
        assert!(used.iter().enumerate().all(|(i, &v)| v == i as f64));
        advise_huge_pages(&mut used[3..1000]);
        advise_huge_pages::<f64>(&mut []);
    }

    #[test]
    fn an_unpooled_read_holds_the_file() {
        let dir = std::env::temp_dir().join(format!("hdrflow-unpooled-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (empty, small) = (dir.join("empty"), dir.join("small"));
        std::fs::write(&empty, b"").unwrap();
        let data: Vec<u8> = (0..100_000u32).map(|i| (i * 7) as u8).collect();
        std::fs::write(&small, &data).unwrap();
        assert!(read_file_unpooled(&empty).unwrap().is_empty());
        let read = read_file_unpooled(&small).unwrap();
        assert_eq!(read, data);
        assert!(read.capacity() >= MMAP_THRESHOLD);
        assert!(read_file_unpooled(&dir.join("missing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
