//! The items of a batch: axes (`--over`, `--sweep`), their cross product or pairing, each
//! item's folder, and shards (steps 1 and 2 of the module doc of `batch`).

use std::collections::HashMap;
use std::path::Path;

use crate::engine::graph::Override;

/// One axis of a batch: a field and the values it takes.
#[derive(Clone, Debug)]
pub struct Axis {
    pub node: String,
    pub field: String,
    pub values: Vec<String>,
    /// From `--over` (values are usually paths: `{stem}` comes from the first such axis).
    pub over: bool,
}

impl Axis {
    /// Parses `NODE.FIELD=V1,V2,...` (`(0,1,0),(1,0,0)` is two tuples). For `--over`, each
    /// value with `*`, `?` or `[` is a glob, replaced by its matching files, sorted
    /// (`maps/*_1k.hdr,extra/one.hdr` is every match, then the one file); a glob ending in `/`
    /// is replaced by its matching folders, each with its `/` (`captures/*/`: one capture
    /// folder per item, named by the folder).
    pub fn parse(s: &str, over: bool) -> Result<Axis, String> {
        let flag = if over { "--over" } else { "--sweep" };
        let o = Override::parse(s).map_err(|e| e.replace("--set", flag))?;
        let mut values = Vec::new();
        for item in split_list(&o.value) {
            if !(over && item.contains(['*', '?', '['])) {
                values.push(item);
                continue;
            }
            // A glob ending in `/` matches folders (one capture folder per item), kept with their
            // slash; any other glob matches files.
            let folders = item.ends_with('/');
            let pattern = if folders { item.trim_end_matches('/') } else { item.as_str() };
            let mut matches = Vec::new();
            for entry in glob::glob(pattern).map_err(|e| format!("{flag} {s:?}: bad pattern {item:?}: {e}"))? {
                let path = entry.map_err(|e| format!("{flag} {s:?}: {e}"))?;
                if folders && path.is_dir() {
                    matches.push(format!("{}/", path.display()));
                } else if !folders && path.is_file() {
                    matches.push(path.display().to_string());
                }
            }
            if matches.is_empty() {
                let what = if folders { "folder" } else { "file" };
                return Err(format!("{flag} {s:?}: no {what} matches {item:?}"));
            }
            matches.sort();
            values.extend(matches);
        }
        if values.iter().any(|v| v.is_empty()) {
            return Err(format!("{flag} {s:?}: an empty value"));
        }
        Ok(Axis { node: o.node, field: o.field, values, over })
    }

    pub fn label(&self) -> String {
        format!("{}.{}", self.node, self.field)
    }
}

/// Splits a comma-separated list at the commas outside brackets and quotes (`(0,1,0),(1,0,0)`
/// is two tuples).
fn split_list(s: &str) -> Vec<String> {
    let mut out = Vec::new();
    let (mut depth, mut quoted, mut cur) = (0i32, false, String::new());
    for c in s.chars() {
        match c {
            '"' => quoted = !quoted,
            '(' | '[' if !quoted => depth += 1,
            ')' | ']' if !quoted => depth -= 1,
            ',' if !quoted && depth == 0 => {
                out.push(cur.trim().to_string());
                cur.clear();
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    out.push(cur.trim().to_string());
    out
}

/// One item of a batch.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Item {
    /// Position in the whole batch (before sharding).
    pub index: usize,
    /// The item's folder, relative to the batch's output folder (also its name in reports).
    pub dir: String,
    /// `NODE.FIELD` and value, one per axis.
    pub values: Vec<(String, String)>,
}

/// The default folder template: `{stem}` of the first `--over`, then `FIELD={FIELD}` parts for
/// the other axes (`NODE.FIELD=` when two axes share a field name).
pub fn default_template(axes: &[Axis]) -> String {
    let mut parts = Vec::new();
    let first_over = axes.iter().position(|a| a.over);
    for (i, a) in axes.iter().enumerate() {
        if Some(i) == first_over {
            parts.push("{stem}".to_string());
        } else {
            let shared = axes.iter().filter(|b| b.field == a.field).count() > 1;
            let name = if shared { a.label() } else { a.field.clone() };
            parts.push(format!("{name}={{{}}}", a.label()));
        }
    }
    parts.join("/")
}

/// A value as a folder-name part: `--over` paths (a `/` or a letters-only extension) give
/// their stem; anything but letters, digits and
/// `.-_+=` becomes `_`.
fn path_part(value: &str, over: bool) -> String {
    let has_ext =
        Path::new(value).extension().is_some_and(|e| e.to_string_lossy().chars().all(|c| c.is_ascii_alphabetic()));
    let v = if over && (value.contains('/') || has_ext) {
        Path::new(value).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| value.to_string())
    } else {
        value.trim_matches('"').to_string()
    };
    v.chars().map(|c| if c.is_ascii_alphanumeric() || "-_.+=".contains(c) { c } else { '_' }).collect()
}

/// Expands the axes into items (cross product, or pairs with `zip`) with their folders.
pub fn items(axes: &[Axis], zip: bool, template: Option<&str>) -> Result<Vec<Item>, String> {
    if axes.is_empty() {
        return Err("a batch needs at least one --over or --sweep".into());
    }
    let combos: Vec<Vec<usize>> = if zip {
        let n = axes[0].values.len();
        if let Some(a) = axes.iter().find(|a| a.values.len() != n) {
            return Err(format!("--zip: {} has {} values but {} has {n}", a.label(), a.values.len(), axes[0].label()));
        }
        (0..n).map(|i| vec![i; axes.len()]).collect()
    } else {
        let mut combos = vec![vec![]];
        for a in axes {
            combos = combos
                .into_iter()
                .flat_map(|c: Vec<usize>| {
                    (0..a.values.len()).map(move |j| {
                        let mut c = c.clone();
                        c.push(j);
                        c
                    })
                })
                .collect();
        }
        combos
    };
    let template = template.map(str::to_string).unwrap_or_else(|| default_template(axes));
    let first_over = axes.iter().position(|a| a.over).unwrap_or(0);
    let mut out = Vec::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    for (index, combo) in combos.iter().enumerate() {
        let first = &axes[first_over].values[combo[first_over]];
        let mut dir = template
            .replace("{stem}", &path_part(first, true))
            .replace(
                "{name}",
                &path_part(&Path::new(first).file_name().map(|s| s.to_string_lossy()).unwrap_or_default(), false),
            )
            .replace("{index}", &index.to_string());
        for (a, &j) in axes.iter().zip(combo) {
            dir = dir.replace(&format!("{{{}}}", a.label()), &path_part(&a.values[j], a.over));
        }
        if let Some(bad) = dir.find('{').map(|i| &dir[i..]) {
            return Err(format!("--item-dir {template:?}: unknown placeholder in {bad:?}"));
        }
        let rel = Path::new(&dir);
        if dir.is_empty()
            || rel.is_absolute()
            || rel.components().any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            return Err(format!("--item-dir {template:?}: item {index} gets folder {dir:?}, not a relative folder"));
        }
        if let Some(other) = seen.insert(dir.clone(), index) {
            return Err(format!(
                "items {other} and {index} both map to folder {dir:?}; give --item-dir a template that tells them apart (e.g. add {{index}})"
            ));
        }
        let values = axes.iter().zip(combo).map(|(a, &j)| (a.label(), a.values[j].clone())).collect();
        out.push(Item { index, dir, values });
    }
    Ok(out)
}

/// Keeps the items of shard `i` of `n`: those whose index is congruent to `i` mod `n`.
pub fn shard(items: Vec<Item>, i: usize, n: usize) -> Vec<Item> {
    items.into_iter().filter(|it| it.index % n == i).collect()
}

#[cfg(test)]
mod tests {
    use super::Axis;

    /// Issue 25.6: a comma-separated `--over` list expands each glob and keeps plain names.
    #[test]
    fn an_over_list_mixing_a_glob_and_a_file_expands_each_item() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b_1k.hdr", "a_1k.hdr", "c_2k.hdr"] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        let d = dir.path().display();
        let axis = Axis::parse(&format!("env.path={d}/*_1k.hdr,{d}/c_2k.hdr"), true).unwrap();
        let names: Vec<String> =
            axis.values.iter().map(|v| v.rsplit('/').next().unwrap_or_default().to_string()).collect();
        assert_eq!(names, ["a_1k.hdr", "b_1k.hdr", "c_2k.hdr"]);
        let err = Axis::parse(&format!("env.path={d}/*_4k.hdr,{d}/c_2k.hdr"), true).unwrap_err();
        assert!(err.ends_with(&format!("no file matches \"{d}/*_4k.hdr\"")), "{err}");
        // --sweep values are never globs.
        assert_eq!(Axis::parse("e.stops=1,2", false).unwrap().values, ["1", "2"]);
    }

    /// Issue 38: `--over brackets.paths='captures/*/'` gives one item per capture folder.
    #[test]
    fn an_over_glob_ending_in_a_slash_matches_folders_only() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["kitchen", "attic"] {
            std::fs::create_dir(dir.path().join(name)).unwrap();
        }
        std::fs::write(dir.path().join("notes.txt"), b"").unwrap();
        let d = dir.path().display();
        let axis = Axis::parse(&format!("brackets.paths={d}/*/"), true).unwrap();
        assert_eq!(axis.values, [format!("{d}/attic/"), format!("{d}/kitchen/")]);
        let items = super::items(&[axis], false, None).unwrap();
        let dirs: Vec<&str> = items.iter().map(|i| i.dir.as_str()).collect();
        assert_eq!(dirs, ["attic", "kitchen"]);
        // Without the slash, the same glob matches files only.
        let files = Axis::parse(&format!("brackets.paths={d}/*"), true).unwrap();
        assert_eq!(files.values, [format!("{d}/notes.txt")]);
        let err = Axis::parse(&format!("brackets.paths={d}/none*/"), true).unwrap_err();
        assert!(err.contains("no folder matches"), "{err}");
    }
}
