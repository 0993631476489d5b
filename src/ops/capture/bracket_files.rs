//! The files of one bracket, for `LoadBrackets`: which files a `paths` value names (a glob, or a
//! folder with or without its trailing `/`), in name order, and the checks that a set of frames
//! makes one bracket (one size, one bit depth, at least two frames, one exposure time each, no
//! two alike). The same checks run at validation on the files' headers and EXIF, and at the
//! run on the decoded frames, so a file that changed in between is still caught; each message
//! names the frame.

use std::path::{Path, PathBuf};

use crate::engine::op::resolve_path;
use crate::formats::photo::EXTENSIONS;
use crate::values::brackets::format_time;

/// One file of a bracket: its path and its name as messages and the brackets value give it.
#[derive(Clone, Debug, PartialEq)]
pub struct BracketFile {
    pub path: PathBuf,
    pub name: String,
}

/// Does `paths` hold glob characters (`*`, `?`, `[`)?
pub fn is_glob(paths: &str) -> bool {
    paths.contains(['*', '?', '['])
}

fn is_photo(path: &Path) -> bool {
    path.extension().is_some_and(|e| EXTENSIONS.contains(&e.to_string_lossy().to_lowercase().as_str()))
}

fn file(path: PathBuf) -> BracketFile {
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    BracketFile { path, name }
}

/// The files `paths` names, relative to `base_dir`, in name order: a glob's matching files, or
/// the photographs (`.jpg`, `.jpeg`, `.png`, `.tif`, `.tiff`, any case) in a folder. A glob or
/// folder that gives no file is an error, as is a path that is neither.
pub fn list(base_dir: &Path, paths: &str) -> Result<Vec<BracketFile>, String> {
    let mut files: Vec<PathBuf> = if is_glob(paths) {
        let pattern = if Path::new(paths).is_absolute() || base_dir.as_os_str().is_empty() {
            paths.to_string()
        } else {
            format!("{}/{paths}", glob::Pattern::escape(&base_dir.to_string_lossy()))
        };
        let matches = glob::glob(&pattern).map_err(|e| format!("bad glob {paths:?}: {e}"))?;
        let files: Vec<PathBuf> = matches.filter_map(Result::ok).filter(|p| p.is_file()).collect();
        if files.is_empty() {
            return Err(format!("no file matches {paths:?} (relative to the pipeline file's folder)"));
        }
        files
    } else {
        let full = resolve_path(base_dir, paths);
        if full.is_file() {
            vec![full]
        } else if full.is_dir() {
            let entries = std::fs::read_dir(&full).map_err(|e| format!("folder {paths:?} cannot be read: {e}"))?;
            let files: Vec<PathBuf> =
                entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file() && is_photo(p)).collect();
            if files.is_empty() {
                return Err(format!("folder {paths:?} holds no photograph (.{})", EXTENSIONS.join(", .")));
            }
            files
        } else {
            return Err(format!(
                "{paths:?} is neither a folder nor a file (looked for {}: a path is relative to the pipeline file's folder)",
                full.display()
            ));
        }
    };
    files.sort();
    Ok(files.into_iter().map(file).collect())
}

/// Which field a bracket problem belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blame {
    Paths,
    ExposureTimes,
}

/// What is known of one frame before the bracket is assembled: its name, size, bits per channel
/// and EXIF exposure time.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFacts {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub bit_depth: u8,
    pub exif_time: Option<f64>,
}

/// Checks that the frames (in name order) make one bracket and returns their exposure times
/// (from `given`, one per frame in name order, else from EXIF), or the problem and its field.
pub fn times(frames: &[FrameFacts], given: Option<&[f64]>) -> Result<Vec<f64>, (Blame, String)> {
    let Some(first) = frames.first() else {
        return Err((Blame::Paths, "no frame".into()));
    };
    if frames.len() < 2 {
        return Err((Blame::Paths, format!("a bracket needs at least two frames; found only {}", first.name)));
    }
    for f in &frames[1..] {
        if (f.width, f.height) != (first.width, first.height) {
            return Err((
                Blame::Paths,
                format!(
                    "frame {} is {}x{}, but {} is {}x{}: every frame of a bracket has one size",
                    f.name, f.width, f.height, first.name, first.width, first.height
                ),
            ));
        }
        if f.bit_depth != first.bit_depth {
            let (odd, other) = if f.bit_depth == 16 { (f, first) } else { (first, f) };
            return Err((
                Blame::Paths,
                format!(
                    "frame {} has {} bits per channel, but {} has {}: every frame of a bracket has one bit depth",
                    odd.name, odd.bit_depth, other.name, other.bit_depth
                ),
            ));
        }
    }
    let times: Vec<f64> = match given {
        Some(t) if t.len() != frames.len() => {
            return Err((
                Blame::ExposureTimes,
                format!(
                    "{} exposure times for {} files: give one per file, in name order ({} ... {})",
                    t.len(),
                    frames.len(),
                    first.name,
                    frames[frames.len() - 1].name
                ),
            ))
        }
        Some(t) => {
            if let Some((f, v)) = frames.iter().zip(t).find(|(_, v)| !(v.is_finite() && **v > 0.0)) {
                return Err((Blame::ExposureTimes, format!("exposure time {v} for {} is not a positive number of seconds", f.name)));
            }
            t.to_vec()
        }
        None => frames
            .iter()
            .map(|f| {
                f.exif_time.ok_or_else(|| {
                    (
                        Blame::Paths,
                        format!(
                            "frame {} has no EXIF exposure time: give exposure_times (seconds, one per file in name order)",
                            f.name
                        ),
                    )
                })
            })
            .collect::<Result<_, _>>()?,
    };
    for i in 0..times.len() {
        for j in i + 1..times.len() {
            if times[i] == times[j] {
                let blame = if given.is_some() { Blame::ExposureTimes } else { Blame::Paths };
                return Err((
                    blame,
                    format!(
                        "frames {} and {} have the same exposure time {}: a bracket's exposures differ",
                        frames[i].name,
                        frames[j].name,
                        format_time(times[i])
                    ),
                ));
            }
        }
    }
    Ok(times)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts(name: &str, w: usize, bits: u8, t: Option<f64>) -> FrameFacts {
        FrameFacts { name: name.into(), width: w, height: 2, bit_depth: bits, exif_time: t }
    }

    #[test]
    fn a_folder_lists_its_photographs_in_name_order_with_or_without_the_slash() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("kitchen");
        std::fs::create_dir(&sub).unwrap();
        for n in ["b.JPG", "a.tif", "c.png", "notes.txt"] {
            std::fs::write(sub.join(n), b"x").unwrap();
        }
        for paths in ["kitchen", "kitchen/"] {
            let names: Vec<String> = list(dir.path(), paths).unwrap().into_iter().map(|f| f.name).collect();
            assert_eq!(names, ["a.tif", "b.JPG", "c.png"], "{paths}");
        }
        let names: Vec<String> = list(dir.path(), "kitchen/*.png").unwrap().into_iter().map(|f| f.name).collect();
        assert_eq!(names, ["c.png"]);
        assert!(list(dir.path(), "kitchen/*.exr").unwrap_err().starts_with("no file matches \"kitchen/*.exr\""));
        std::fs::create_dir(dir.path().join("empty")).unwrap();
        assert!(list(dir.path(), "empty/").unwrap_err().contains("holds no photograph"));
        assert!(list(dir.path(), "nowhere/").unwrap_err().contains("is neither a folder nor a file"));
    }

    #[test]
    fn each_bad_bracket_is_named() {
        let ok = [facts("a", 4, 8, Some(0.01)), facts("b", 4, 8, Some(0.04))];
        assert_eq!(times(&ok, None).unwrap(), [0.01, 0.04]);
        assert_eq!(times(&ok, Some(&[1.0, 2.0])).unwrap(), [1.0, 2.0]);
        let err = |f: &[FrameFacts], g: Option<&[f64]>| times(f, g).unwrap_err();
        assert!(err(&ok[..1], None).1.contains("at least two frames; found only a"));
        let e = err(&[ok[0].clone(), facts("b", 5, 8, Some(0.04))], None);
        assert_eq!(e.0, Blame::Paths);
        assert!(e.1.starts_with("frame b is 5x2, but a is 4x2"), "{}", e.1);
        let e = err(&[ok[0].clone(), facts("b", 4, 16, Some(0.04))], None).1;
        assert!(e.starts_with("frame b has 16 bits per channel, but a has 8"), "{e}");
        let e = err(&[ok[0].clone(), facts("b", 4, 8, Some(0.01))], None).1;
        assert!(e.contains("frames a and b have the same exposure time 1/100 s"), "{e}");
        let e = err(&[ok[0].clone(), facts("b", 4, 8, None)], None).1;
        assert!(e.contains("frame b has no EXIF exposure time: give exposure_times"), "{e}");
        let e = err(&ok, Some(&[1.0]));
        assert_eq!(e.0, Blame::ExposureTimes);
        assert!(e.1.starts_with("1 exposure times for 2 files"), "{}", e.1);
        assert_eq!(err(&ok, Some(&[1.0, 1.0])).0, Blame::ExposureTimes);
    }
}
