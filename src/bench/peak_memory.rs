//! Point target: the peak resident memory of `graphs/seed.ron` on an 8192x4096 map, at most 3x
//! the map's float bytes (8192 x 4096 x 3 f32 = 402,653,184 bytes: the map as `LoadHdr` hands
//! it over).
//!
//! Both steps run the `hdrflow` binary itself in a child process, as a user runs it: the map is
//! the built-in sky resized and saved as PFM (the recipe of docs/src/benchmarks/engine.md, `make_map_graph`), then the
//! seed graph runs on it (`run graphs/seed.ron --set env.path=MAP --no-cache --jobs 2 -q`), and its
//! peak is the child's own high-water mark of resident memory (`run_for_peak`). Two workers, as on the
//! 2-core machine the issue measured on: each worker may hold a PNG's 8-bit copy that the run
//! does not count (see `engine::scheduler::admission`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::Target;

/// The map's size.
const WIDTH: usize = 8192;
const HEIGHT: usize = 4096;

/// The graph that makes the map (`MAP_FILE` in its output folder).
fn make_map_graph() -> String {
    format!(
        r#"( nodes: {{ "env": LoadHdr(path: "builtin:sky"), "big": Resize(image: "env", width: {WIDTH}, height: {HEIGHT}),
           "save": Save(input: "big", path: "{MAP_FILE}") }} )"#
    )
}

/// The map's file name.
const MAP_FILE: &str = "sky_big.pfm";

/// The goal: peak resident memory over the map's float bytes.
const GOAL_RATIO: f64 = 3.0;

/// The `hdrflow` binary to run: `HDRFLOW_BIN`, else this process's own executable when it is
/// `hdrflow` (the target runs from `hdrflow bench`).
pub(crate) fn hdrflow_binary() -> Result<PathBuf, String> {
    if let Some(bin) = std::env::var_os("HDRFLOW_BIN") {
        return Ok(PathBuf::from(bin));
    }
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    if exe.file_stem().is_some_and(|s| s == "hdrflow") {
        Ok(exe)
    } else {
        Err(format!("{} is not the hdrflow binary (set HDRFLOW_BIN)", exe.display()))
    }
}

/// The target, measured (`met: None` with the reason when it cannot be measured here).
pub fn seed_peak(log: &dyn Fn(&str)) -> Target {
    let name = format!("graphs/seed.ron peak resident memory on a {WIDTH}x{HEIGHT} map, --jobs 2");
    let goal = format!("<= {GOAL_RATIO}x the map's float bytes");
    let dir = std::env::temp_dir().join(format!("hdrflow-bench-peak-{}", std::process::id()));
    let result = measure(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    match result {
        Ok((peak, seconds)) => {
            let map = (WIDTH * HEIGHT * 3 * 4) as f64;
            let ratio = peak as f64 / map;
            log(&format!(
                "graphs/seed.ron on {WIDTH}x{HEIGHT}: peak RSS {:.0} MiB = {ratio:.2}x the map's {:.0} MiB, {seconds:.1} s",
                peak as f64 / 1048576.0,
                map / 1048576.0
            ));
            Target {
                name,
                measured: format!(
                    "{:.0} MiB = {ratio:.2}x the map's {:.0} MiB (wall time {seconds:.1} s)",
                    peak as f64 / 1048576.0,
                    map / 1048576.0
                ),
                goal,
                met: Some(ratio <= GOAL_RATIO),
            }
        }
        Err(e) => {
            log(&format!("SKIPPED seed graph peak memory: {e}"));
            Target { name, measured: format!("not measured: {e}"), goal, met: None }
        }
    }
}

/// Writes the map into `dir`, runs the seed graph on it; (peak resident bytes, wall seconds).
fn measure(dir: &Path) -> Result<(u64, f64), String> {
    let bin = hdrflow_binary()?;
    std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    let make = dir.join("make_big.ron");
    std::fs::write(&make, make_map_graph()).map_err(|e| e.to_string())?;
    let made = std::process::Command::new(&bin)
        .arg("run")
        .arg(&make)
        .args(["--no-cache", "-q", "--out"])
        .arg(dir)
        .status()
        .map_err(|e| format!("{}: {e}", bin.display()))?;
    if !made.success() {
        return Err(format!("{} run make_big.ron exited with {made}", bin.display()));
    }
    let map_path = dir.join(MAP_FILE);
    let seed = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/seed.ron");
    let mut command = std::process::Command::new(&bin);
    command
        .arg("run")
        .arg(&seed)
        .arg("--set")
        .arg(format!("env.path={}", map_path.display()))
        .args(["--no-cache", "--jobs", "2", "-q", "--out"])
        .arg(dir.join("out"));
    let t0 = Instant::now();
    let (ok, peak) = run_for_peak(&mut command)?;
    let seconds = t0.elapsed().as_secs_f64();
    if !ok {
        return Err(format!("{} run graphs/seed.ron failed", bin.display()));
    }
    Ok((peak, seconds))
}

/// Runs `command` to its end; (whether it succeeded, its peak resident bytes). The peak is the
/// child's `VmHWM` (the high-water mark of its own resident memory since its exec) read from
/// `/proc` every 2 ms while it runs, the last read before it exits: only a new peak in its last
/// 2 ms could be missed. `getrusage`/`wait4`'s `ru_maxrss` would not do: Linux carries the
/// spawning process's own high-water mark into the child's at exec, and this process has held
/// the 16384x8192 maps of target 2 by then.
#[cfg(target_os = "linux")]
pub(crate) fn run_for_peak(command: &mut std::process::Command) -> Result<(bool, u64), String> {
    let mut child = command.spawn().map_err(|e| e.to_string())?;
    let status_path = format!("/proc/{}/status", child.id());
    let mut peak = 0u64;
    loop {
        if let Some(kib) = std::fs::read_to_string(&status_path).ok().as_deref().and_then(vm_hwm_kib) {
            peak = peak.max(kib * 1024);
        }
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            if peak == 0 {
                return Err(format!("no VmHWM read from {status_path}"));
            }
            return Ok((status.success(), peak));
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

/// The `VmHWM:` line of a `/proc/PID/status`, in KiB.
#[cfg(target_os = "linux")]
fn vm_hwm_kib(status: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(not(target_os = "linux"))]
pub(crate) fn run_for_peak(_: &mut std::process::Command) -> Result<(bool, u64), String> {
    Err("the peak of a child process is read from /proc on Linux only".into())
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    #[test]
    fn the_high_water_mark_is_read_from_a_proc_status() {
        let status = "Name:\thdrflow\nVmPeak:\t  2000000 kB\nVmHWM:\t  1061668 kB\nVmRSS:\t   120000 kB\n";
        assert_eq!(super::vm_hwm_kib(status), Some(1061668));
        assert_eq!(super::vm_hwm_kib("Name:\tzombie\n"), None);
    }
}
