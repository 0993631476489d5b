//! A test whose subject is missing (a data folder, a service, a browser) skips visibly: a banner
//! written straight to the process's stderr, past the test harness's capture (which swallows
//! `eprintln!` of passing tests, so a skip used to look like a pass), and a failure when the
//! named `HDRFLOW_REQUIRE_*` variable is `1`, as `.ci/run` sets every one of them (but
//! `HDRFLOW_REQUIRE_AVX512`, for the SIMD tests that need a processor with AVX-512: set it on a
//! machine that has one).
//!
//! One file for the unit tests (`crate::test_skip`) and the integration tests
//! (`tests/common` includes it with `#[path]`), with [`real_map`], where those tests find a real
//! map by name.

use std::io::Write;

/// Skips the calling test with `what` as the reason, or fails it when `require_var=1`.
#[allow(dead_code)]
pub fn skip(require_var: &str, what: &str) {
    if std::env::var(require_var).is_ok_and(|v| v == "1") {
        panic!("{require_var}=1 but {what}");
    }
    let banner = "=".repeat(78);
    let thread = std::thread::current();
    let test = thread.name().unwrap_or("a test");
    let _ = writeln!(
        std::io::stderr().lock(),
        "{banner}\nSKIPPED {test}: {what}\n(set {require_var}=1 to make this a failure)\n{banner}"
    );
}

/// [`skip`] for the real maps of `../shared/data`, outside the repository
/// (`HDRFLOW_REQUIRE_DATA`).
#[allow(dead_code)]
pub fn skip_missing_data(what: &str) {
    skip("HDRFLOW_REQUIRE_DATA", what)
}

/// A real environment map by file name: the copy that ships in `assets/maps/` when there is one
/// (the park, the interior and the studio), else `../shared/data/envmaps/NAME` beside the
/// repository (Grace Cathedral's maps), which may be missing: callers then skip with
/// [`skip_missing_data`].
#[allow(dead_code)]
pub fn real_map(name: &str) -> std::path::PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let shipped = root.join("assets/maps").join(name);
    if shipped.is_file() {
        shipped
    } else {
        root.join("../shared/data/envmaps").join(name)
    }
}
