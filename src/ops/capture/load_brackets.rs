//! `LoadBrackets(paths, exposure_times)`: the photographs of one bracketed exposure sequence as
//! a `brackets` value: integer codes (8 or 16 bits, RGB, EXIF orientation applied), each frame's
//! exposure time, sorted from the shortest exposure to the longest.
//!
//! `paths` is a glob (`"captures/kitchen/*.jpg"`) or a folder (`"captures/kitchen/"`, with or
//! without the slash: every `.jpg`, `.jpeg`, `.png`, `.tif`, `.tiff` in it), relative to the
//! pipeline file; the files are taken in name order (`bracket_files`). Times come from each
//! file's EXIF ExposureTime, unless `exposure_times` gives them (seconds, one per file in name
//! order). The frames stay integer codes: seven 24-megapixel frames are 504 MB as bytes and
//! 2 GB as f32.
//!
//! Validation lists the files and reads their headers and EXIF, so frames of different sizes
//! (the message names the frame), a single frame, two frames with one exposure time, no EXIF
//! time and no `exposure_times`, a count of `exposure_times` that differs from the files, a
//! 16-bit frame among 8-bit ones, a file that is not an image and an empty folder or glob are
//! pipeline errors before anything runs; the run checks the decoded frames again. The cache key
//! is every file's name, in order, and BLAKE3 content hash, plus the times; not the `paths` text
//! (an `InputPattern`, which keys leave out like an input file's path), so moving the captures,
//! or running on another machine with them elsewhere, keeps the key. Frames
//! are decoded in parallel.

use std::path::Path;

use rayon::prelude::*;

use super::bracket_files::{self, Blame, BracketFile, FrameFacts};
use crate::engine::fields::Check;
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Size};
use crate::engine::params::InputPattern;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::formats::photo;
use crate::values::brackets::{Brackets, Frame};
use crate::values::ty::*;

crate::params! {
    pub struct LoadBracketsParams {
        /// a folder of photographs (with or without a trailing /) or a glob (`captures/kitchen/*.jpg`), relative to the pipeline file; files in name order
        pub paths: InputPattern,
        /// the exposure times in seconds, one per file in name order; absent: each file's EXIF ExposureTime
        #[range(0.0, 1e6)]
        pub exposure_times: Option<Vec<f64>>,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LoadBrackets",
        1,
        "Load a bracketed exposure sequence (a folder or glob of PNG, JPEG or TIFF files) as integer frames with their exposure times",
        eval,
    )
    .output("brackets", BRACKETS_T, "the frames as 8- or 16-bit codes with their exposure times, shortest first")
    .check(check)
    .size(size)
    .content_key(content_key)
    .into()
}

fn problem(blame: Blame, message: String) -> CheckProblem {
    match blame {
        Blame::Paths => CheckProblem::at(LoadBracketsParams::paths, message),
        Blame::ExposureTimes => CheckProblem::at(LoadBracketsParams::exposure_times, message),
    }
}

/// A file's header and (unless the times are given) its EXIF time, read without decoding pixels.
fn facts(file: &BracketFile, need_time: bool) -> Result<FrameFacts, String> {
    let h = photo::header(&file.path).map_err(|m| format!("file {} {m}", file.name))?;
    let exif_time = if need_time {
        let bytes = crate::memory::read_file_unpooled(&file.path)
            .map_err(|e| format!("file {} cannot be read: {e}", file.name))?;
        photo::exif::read(&bytes).exposure_time
    } else {
        None
    };
    Ok(FrameFacts { name: file.name.clone(), width: h.width, height: h.height, bit_depth: h.bit_depth, exif_time })
}

fn check(ctx: &CheckContext, p: LoadBracketsParams<Check>) -> Result<(), CheckProblem> {
    let files = bracket_files::list(ctx.base_dir, &p.paths.0).map_err(|m| problem(Blame::Paths, m))?;
    let given = p.exposure_times.as_deref();
    let facts: Vec<FrameFacts> = files
        .par_iter()
        .map(|f| facts(f, given.is_none()))
        .collect::<Result<_, _>>()
        .map_err(|m| problem(Blame::Paths, m))?;
    bracket_files::times(&facts, given).map(|_| ()).map_err(|(b, m)| problem(b, m))
}

/// The first file's size (every frame's, once validation has passed).
fn size(ctx: &CheckContext, p: LoadBracketsParams<Check>) -> Size {
    let files = bracket_files::list(ctx.base_dir, &p.paths.0).ok()?;
    let h = photo::header(&files.first()?.path).ok()?;
    Some((h.width as u64, h.height as u64))
}

/// Name, then content hash, of every file in name order.
fn key_of(parts: &[(String, blake3::Hash)]) -> Vec<u8> {
    let mut key = Vec::new();
    for (name, hash) in parts {
        key.extend_from_slice(&(name.len() as u64).to_le_bytes());
        key.extend_from_slice(name.as_bytes());
        key.extend_from_slice(hash.as_bytes());
    }
    key
}

fn content_key(p: LoadBracketsParams<Check>, base_dir: &Path) -> Result<Vec<u8>, OpError> {
    let files = bracket_files::list(base_dir, &p.paths.0).map_err(OpError::Invalid)?;
    let parts = files
        .par_iter()
        .map(|f| {
            let bytes = crate::memory::read_file_unpooled(&f.path)
                .map_err(|source| OpError::Io { path: f.path.clone(), source })?;
            Ok((f.name.clone(), blake3::hash(&bytes)))
        })
        .collect::<Result<Vec<_>, OpError>>()?;
    Ok(key_of(&parts))
}

fn eval(ctx: &mut OpContext, p: LoadBracketsParams) -> Result<Value, OpError> {
    let files = bracket_files::list(ctx.base_dir, &p.paths.0).map_err(OpError::Invalid)?;
    let decoded = files
        .par_iter()
        .map(|f| {
            let bytes = crate::memory::read_file_unpooled(&f.path)
                .map_err(|source| OpError::Io { path: f.path.clone(), source })?;
            let hash = blake3::hash(&bytes);
            let photo = photo::decode(&bytes)
                .map_err(|m| OpError::Format { path: f.path.clone(), message: format!("the file {m}") })?;
            Ok((hash, photo))
        })
        .collect::<Result<Vec<_>, OpError>>()?;
    // The key was made from the files' hashes before the run; other bytes would be cached under it.
    let parts: Vec<(String, blake3::Hash)> =
        files.iter().zip(&decoded).map(|(f, (h, _))| (f.name.clone(), *h)).collect();
    if ctx.content_key.is_some_and(|key| key != key_of(&parts).as_slice()) {
        return Err(OpError::Invalid(format!(
            "the files of {:?} changed while hdrflow was running; run again",
            p.paths.0
        )));
    }
    let facts: Vec<FrameFacts> = files
        .iter()
        .zip(&decoded)
        .map(|(f, (_, ph))| FrameFacts {
            name: f.name.clone(),
            width: ph.width,
            height: ph.height,
            bit_depth: ph.codes.bits(),
            exif_time: ph.exif.exposure_time,
        })
        .collect();
    let times = bracket_files::times(&facts, p.exposure_times.as_deref()).map_err(|(_, m)| OpError::Invalid(m))?;
    let (width, height, bits) = (facts[0].width, facts[0].height, facts[0].bit_depth);
    let frames = files
        .into_iter()
        .zip(decoded)
        .zip(times)
        .map(|((f, (_, ph)), time)| Frame { name: f.name, time, codes: ph.codes, covered: None })
        .collect();
    let brackets = Brackets::new(width, height, bits, frames).map_err(OpError::Invalid)?;
    Ok(Value::new(brackets))
}
