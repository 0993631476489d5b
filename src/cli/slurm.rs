//! `hdrflow batch --emit-slurm` and `--failed-shards`: the script side of running a batch as a
//! Slurm job array. Nothing here talks to Slurm; the scripts do (`tests/batch_slurm.rs` runs them
//! through a fake `sbatch`).

use std::path::{Path, PathBuf};

use crate::batch::Item;

/// Quotes `s` for a POSIX shell: unchanged if it is made only of characters no shell treats
/// specially, otherwise in single quotes (a `'` inside becomes `'\''`).
pub(crate) fn sh_quote(s: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "_./=:,+@%-".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// One `#SBATCH` line: `--KEY=VALUE`, or `--KEY` for a flag.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct SbatchLine {
    pub key: String,
    pub value: Option<String>,
}

impl SbatchLine {
    fn render(&self) -> String {
        match &self.value {
            // sbatch reads `#SBATCH` lines itself, splitting at blanks outside double quotes.
            Some(v) if v.contains(char::is_whitespace) => format!("#SBATCH --{}=\"{v}\"", self.key),
            Some(v) => format!("#SBATCH --{}={v}", self.key),
            None => format!("#SBATCH --{}", self.key),
        }
    }
}

/// The default lines: array, job name, CPUs per task, output.
pub(crate) fn default_lines(shards: usize, cpus: usize, out: &Path) -> Vec<SbatchLine> {
    let line = |k: &str, v: String| SbatchLine { key: k.to_string(), value: Some(v) };
    vec![
        line("array", format!("0-{}", shards - 1)),
        line("job-name", "hdrflow-batch".to_string()),
        line("cpus-per-task", cpus.to_string()),
        line("output", format!("{}/slurm/%A_%a.out", out.display())),
    ]
}

/// Applies `--slurm-arg` values to `lines`: `KEY=VALUE` (a leading `--` on KEY is allowed) replaces
/// the value of the line with the same key, in place, or adds a line at the end; `KEY` alone is a
/// flag line (`#SBATCH --exclusive`), replacing or added the same way.
pub(crate) fn apply_slurm_args(mut lines: Vec<SbatchLine>, args: &[String]) -> Result<Vec<SbatchLine>, String> {
    for a in args {
        let (key, value) = match a.split_once('=') {
            Some((k, v)) => (k, Some(v.to_string())),
            None => (a.as_str(), None),
        };
        let key = key.trim_start_matches("--");
        if key.is_empty() || !key.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
            return Err(format!("--slurm-arg {a:?}: expected KEY=VALUE or KEY (an sbatch long option name)"));
        }
        if value.as_deref().is_some_and(|v| v.contains(['\n', '"'])) {
            return Err(format!("--slurm-arg {a:?}: a value cannot hold a line break or a double quote"));
        }
        let new = SbatchLine { key: key.to_string(), value };
        match lines.iter_mut().find(|l| l.key == new.key) {
            Some(l) => *l = new,
            None => lines.push(new),
        }
    }
    Ok(lines)
}

/// Everything a shard's command line needs, paths already absolute.
pub(crate) struct ScriptSpec {
    pub exe: PathBuf,
    /// The working folder at emit time: the scripts `cd` there, so relative `--over` globs and
    /// values resolve as they did when the script was written.
    pub cwd: PathBuf,
    pub graph: PathBuf,
    /// The options before `--out`, already as separate words (`--over`, `env.path=...`, ...).
    pub options: Vec<String>,
    pub out: PathBuf,
    pub shards: usize,
    pub lines: Vec<SbatchLine>,
}

impl ScriptSpec {
    fn command(&self, tail: &[String]) -> String {
        let mut words =
            vec![sh_quote(&self.exe.to_string_lossy()), "batch".into(), sh_quote(&self.graph.to_string_lossy())];
        words.extend(self.options.iter().map(|o| sh_quote(o)));
        words.push("--out".into());
        words.push(sh_quote(&self.out.to_string_lossy()));
        words.extend(tail.iter().cloned());
        words.join(" ")
    }

    /// The `sbatch` script: one array element per shard.
    pub(crate) fn sbatch_script(&self) -> String {
        let n = self.shards;
        let mut s = String::from("#!/bin/bash\n");
        for l in &self.lines {
            s.push_str(&l.render());
            s.push('\n');
        }
        s.push_str(&format!(
            "# Written by `hdrflow batch --emit-slurm`: shard $SLURM_ARRAY_TASK_ID of {n} per array element.\n\
             # The cache and output folders must be on a filesystem every node sees.\n\
             # Which shards finished is decided from their reports (shards/shard-I-of-{n}.json):\n\
             # run the .resubmit script next to this one to resubmit the others.\n"
        ));
        s.push_str("set -euo pipefail\n");
        s.push_str(&format!("cd {}\n", sh_quote(&self.cwd.to_string_lossy())));
        let report = format!(
            "{}\"$SLURM_ARRAY_TASK_ID\"{}",
            sh_quote(&format!("{}/shards/shard-", self.out.display())),
            sh_quote(&format!("-of-{n}.json"))
        );
        let tail = ["--shard".to_string(), format!("\"$SLURM_ARRAY_TASK_ID/{n}\""), "--report".to_string(), report];
        s.push_str(&format!("exec {}\n", self.command(&tail)));
        s
    }

    /// The companion script: lists the shards whose report is missing or not all done, and
    /// resubmits exactly those.
    pub(crate) fn resubmit_script(&self, sbatch_file: &Path) -> String {
        let n = self.shards;
        let list = self.command(&["--failed-shards".to_string(), n.to_string()]);
        format!(
            "#!/bin/sh\n\
             # Written by `hdrflow batch --emit-slurm`: resubmits the shards that did not finish.\n\
             set -eu\n\
             cd {cwd}\n\
             list=$({list})\n\
             if [ -n \"$list\" ]; then\n\
             \x20   echo \"resubmitting shards $list of {n}\"\n\
             \x20   exec sbatch --array=\"$list\" {file}\n\
             else\n\
             \x20   echo \"all {n} shards finished\"\n\
             fi\n",
            cwd = sh_quote(&self.cwd.to_string_lossy()),
            file = sh_quote(&sbatch_file.to_string_lossy()),
        )
    }
}

/// The report file of shard `i` of `n`.
pub(crate) fn shard_report(out: &Path, i: usize, n: usize) -> PathBuf {
    out.join("shards").join(format!("shard-{i}-of-{n}.json"))
}

/// Why shard `i` of `n` is not finished, or `None` if it is: its report is missing or unreadable,
/// an item of the shard has no row in it, or a row's status is neither `computed` nor `cached`.
pub(crate) fn shard_problem(items: &[Item], out: &Path, i: usize, n: usize) -> Option<String> {
    let path = shard_report(out, i, n);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => return Some(format!("{}: {e}", path.display())),
    };
    let rows: Vec<serde_json::Value> = match serde_json::from_str(&text) {
        Ok(r) => r,
        Err(e) => return Some(format!("{}: not a report: {e}", path.display())),
    };
    for it in items.iter().filter(|it| it.index % n == i) {
        let row = rows.iter().find(|r| r["index"].as_u64() == Some(it.index as u64) && r["item"] == it.dir.as_str());
        match row.and_then(|r| r["status"].as_str()) {
            Some("computed" | "cached") => {}
            Some(s) => return Some(format!("item {:?} {s}", it.dir)),
            None => return Some(format!("item {:?} not in {}", it.dir, path.display())),
        }
    }
    None
}

/// Indices as an `sbatch --array` list, runs of three or more as ranges: `0,2-5,7`.
pub(crate) fn array_list(indices: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut k = 0;
    while k < indices.len() {
        let mut j = k;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        if j >= k + 2 {
            parts.push(format!("{}-{}", indices[k], indices[j]));
        } else {
            parts.extend(indices[k..=j].iter().map(|i| i.to_string()));
        }
        k = j + 1;
    }
    parts.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn through_sh(words: &[&str]) -> Vec<String> {
        let script = format!("printf '%s\\n' {}", words.iter().map(|w| sh_quote(w)).collect::<Vec<_>>().join(" "));
        let out = std::process::Command::new("sh").arg("-c").arg(&script).output().expect("sh runs");
        assert!(out.status.success(), "{script}");
        String::from_utf8(out.stdout).expect("utf8").lines().map(str::to_string).collect()
    }

    #[test]
    fn quoting_survives_the_shell() {
        let words = [
            "plain",
            "/abs/path/m0.pfm",
            "with space",
            "it's",
            "'",
            "''",
            "\"double\"",
            "$HOME",
            "`id`",
            "a\\b",
            "*.pfm",
            "env.path=maps dir/*.hdr",
            "semi;colon&amp|pipe",
            "tab\there",
            "~user",
            "#hash",
            "é unicode",
        ];
        assert_eq!(through_sh(&words), words);
        assert_eq!(sh_quote(""), "''");
        assert_eq!(sh_quote("env.path=/a/b.pfm"), "env.path=/a/b.pfm");
        assert_eq!(sh_quote("it's"), r"'it'\''s'");
    }

    #[test]
    fn slurm_args_replace_in_place_or_append() {
        let lines = default_lines(4, 2, Path::new("/o"));
        let args: Vec<String> = ["time=01:00:00", "--partition=gpu", "cpus-per-task=8", "exclusive", "job-name=x=y"]
            .map(String::from)
            .into();
        let got = apply_slurm_args(lines, &args).unwrap();
        let rendered: Vec<String> = got.iter().map(SbatchLine::render).collect();
        assert_eq!(
            rendered,
            [
                "#SBATCH --array=0-3",
                "#SBATCH --job-name=x=y",
                "#SBATCH --cpus-per-task=8",
                "#SBATCH --output=/o/slurm/%A_%a.out",
                "#SBATCH --time=01:00:00",
                "#SBATCH --partition=gpu",
                "#SBATCH --exclusive",
            ]
        );
        let spaced = default_lines(2, 1, Path::new("/o d"));
        assert_eq!(spaced[3].render(), "#SBATCH --output=\"/o d/slurm/%A_%a.out\"");
        // The last of two values for one key wins.
        let got = apply_slurm_args(vec![], &["time=1".into(), "time=2".into()]).unwrap();
        assert_eq!(got, vec![SbatchLine { key: "time".into(), value: Some("2".into()) }]);
        for (bad, why) in [
            ("=x", "expected KEY=VALUE or KEY"),
            ("a b=1", "expected KEY=VALUE or KEY"),
            ("--=1", "expected KEY=VALUE or KEY"),
            ("t\n=1", "expected KEY=VALUE or KEY"),
            ("time=a\nb", "cannot hold a line break or a double quote"),
            ("comment=\"x\"", "cannot hold a line break or a double quote"),
        ] {
            let e = apply_slurm_args(vec![], &[bad.into()]).unwrap_err();
            assert!(e.starts_with(&format!("--slurm-arg {bad:?}: ")) && e.contains(why), "{bad:?}: {e}");
        }
    }

    #[test]
    fn array_lists() {
        assert_eq!(array_list(&[]), "");
        assert_eq!(array_list(&[3]), "3");
        assert_eq!(array_list(&[0, 1]), "0,1");
        assert_eq!(array_list(&[0, 2, 3, 4, 5, 7, 9, 10]), "0,2-5,7,9,10");
    }
}
