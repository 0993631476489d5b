//! `--python FILE`: Python operators from the command line. The binary holds no Python; a
//! command with `--python` is handed whole to the `hdrflow` Python package, which runs FILE
//! (its `@hdrflow.operator` functions register themselves) and then this same command line
//! inside its extension, over the registry that now has them (`hdrflow._hdrflow.cli_main`).
//! The interpreter is `$HDRFLOW_PYTHON`, else `python3`.

use std::ffi::OsString;
use std::process::ExitCode;

/// The handover: run the operators' file as a script (`__name__ == "__hdrflow_ops__"`), then
/// the command without `--python` (so it cannot hand over again).
const HANDOVER: &str = r#"
import runpy, sys
try:
    import hdrflow._hdrflow as ext
except ImportError as e:
    sys.exit(f"error: --python needs the hdrflow Python package in {sys.executable} (pip install ./python): {e}")
runpy.run_path(sys.argv[1], run_name="__hdrflow_ops__")
sys.exit(ext.cli_main(sys.argv[2:]))
"#;

/// `args` without `--python FILE` / `--python=FILE`, and FILE if it was there.
pub fn take_python_flag(args: Vec<OsString>) -> (Option<OsString>, Vec<OsString>) {
    let mut file = None;
    let mut rest = Vec::with_capacity(args.len());
    let mut it = args.into_iter();
    while let Some(a) = it.next() {
        match a.to_str() {
            Some("--python") => file = it.next().or(Some(OsString::new())),
            Some(s) if s.starts_with("--python=") => file = Some(s["--python=".len()..].into()),
            _ => rest.push(a),
        }
    }
    (file, rest)
}

/// Runs the command (`args`, program name first) in Python with FILE's operators registered.
pub fn hand_over(file: OsString, args: Vec<OsString>) -> ExitCode {
    if file.is_empty() {
        eprintln!("error: --python needs the file that defines the operators, e.g. --python my_ops.py");
        return ExitCode::from(2);
    }
    if !std::path::Path::new(&file).is_file() {
        eprintln!("error: --python {}: no such file", file.to_string_lossy());
        return ExitCode::from(2);
    }
    let python = std::env::var_os("HDRFLOW_PYTHON").unwrap_or_else(|| "python3".into());
    let status = std::process::Command::new(&python).arg("-c").arg(HANDOVER).arg(&file).args(&args).status();
    match status {
        Ok(s) => ExitCode::from(s.code().map_or(1, |c| c.clamp(0, 255) as u8)),
        Err(e) => {
            eprintln!(
                "error: --python: cannot start {} ({e}); set HDRFLOW_PYTHON to the interpreter",
                python.to_string_lossy()
            );
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::take_python_flag;

    #[test]
    fn the_flag_is_taken_out_in_both_spellings() {
        let v = |s: &[&str]| s.iter().map(Into::into).collect::<Vec<std::ffi::OsString>>();
        let (file, rest) = take_python_flag(v(&["hdrflow", "run", "g.ron", "--python", "ops.py", "-q"]));
        assert_eq!((file, rest), (Some("ops.py".into()), v(&["hdrflow", "run", "g.ron", "-q"])));
        let (file, rest) = take_python_flag(v(&["hdrflow", "batch", "--python=x.py", "g.ron"]));
        assert_eq!((file, rest), (Some("x.py".into()), v(&["hdrflow", "batch", "g.ron"])));
        assert_eq!(take_python_flag(v(&["hdrflow", "run", "--python"])).0, Some("".into()));
        assert_eq!(take_python_flag(v(&["hdrflow", "run", "g.ron"])).0, None);
    }
}
