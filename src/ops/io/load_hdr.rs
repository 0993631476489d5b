//! `LoadHdr(path, flip_vertical: false)`: an HDR image from a Radiance `.hdr`, OpenEXR `.exr` or
//! `.pfm` file, or an embedded procedural map `builtin:NAME` (see `formats::builtin`).
//!
//! The cache key holds the file's BLAKE3 content hash and extension, never its path or time:
//! moving a file keeps its key, editing it in place (even with its mtime restored) changes it.

use crate::engine::op::{CheckContext, Size};
use crate::engine::typed_op::Op;
use std::path::Path;

use crate::engine::fields::{Check, Stage};
use crate::engine::op::{resolve_path, OpContext, OpError, OpSpec};
use crate::engine::params::InputPath;
use crate::engine::value::Value;
use crate::formats;
use crate::values::ty::*;

crate::params! {
    pub struct LoadHdrParams {
        /// file path (relative to the pipeline file) or builtin:NAME
        pub path: InputPath,
        /// flip rows after loading (pbrt's grace_latlong.exr is stored upside down)
        pub flip_vertical: bool = false,
        /// EXR: the part to read (0-based); absent: the first part with a colour channel (R, G, B or Y)
        #[range(0, 100000)]
        pub part: Option<usize>,
        /// EXR: a part name, or a channel-name prefix (`diffuse` for `diffuse.R`); absent: none
        pub layer: Option<String>,
        /// EXR: Display (the display window; outside the data window is black) or Data (as stored)
        pub window: formats::Window = formats::Window::Display,
        /// Linear709: convert from the file's primaries (EXR chromaticities, Radiance PRIMARIES) to linear Rec. 709; AsStored: as stored
        pub colorspace: formats::ColorSpace = formats::ColorSpace::Linear709,
    }
}

impl<S: Stage> LoadHdrParams<S> {
    fn options(&self) -> formats::DecodeOptions {
        formats::DecodeOptions {
            part: self.part,
            layer: self.layer.clone(),
            window: self.window,
            colorspace: self.colorspace,
        }
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LoadHdr",
        1,
        "Load an HDR image (.hdr RGBE, .exr, .pfm) or a built-in procedural map (builtin:sky, ...)",
        eval,
    )
    .output("image", IMAGE_T, "the image (RGB, or RGBA for an EXR with alpha)")
    .size(size)
    .content_key(content_key)
    .into()
}

/// Bump when a built-in map's generator changes.
const BUILTIN_VERSION: u32 = 1;

fn content_key(p: LoadHdrParams<Check>, base_dir: &Path) -> Result<Vec<u8>, OpError> {
    let path = p.path.0.as_str();
    if let Some(name) = path.strip_prefix("builtin:") {
        return Ok(format!("builtin:{name}:v{BUILTIN_VERSION}").into_bytes());
    }
    let full = resolve_path(base_dir, path);
    let bytes = std::fs::read(&full).map_err(|source| OpError::Io { path: full.clone(), source })?;
    let mut key = extension(&full).into_bytes();
    key.push(0);
    key.extend_from_slice(blake3::hash(&bytes).as_bytes());
    Ok(key)
}

fn extension(path: &Path) -> String {
    path.extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default()
}

fn eval(ctx: &mut OpContext, p: LoadHdrParams) -> Result<Value, OpError> {
    let path = p.path.0.as_str();
    let mut image = if let Some(name) = path.strip_prefix("builtin:") {
        formats::builtin::builtin(name).ok_or_else(|| {
            let names: Vec<&str> = formats::builtin::BUILTINS.iter().map(|(n, _)| *n).collect();
            OpError::Invalid(format!("no built-in map {name:?} (built-ins: {})", names.join(", ")))
        })?
    } else {
        let full = ctx.path(path);
        let bytes = std::fs::read(&full).map_err(|source| OpError::Io { path: full.clone(), source })?;
        // The key was made from the file's hash before the run; decoding other bytes would
        // cache them under that key.
        if let Some(key) = ctx.content_key {
            if !key.ends_with(blake3::hash(&bytes).as_bytes()) {
                return Err(OpError::Invalid(format!(
                    "{} changed while hdrflow was running; run again",
                    full.display()
                )));
            }
        }
        formats::decode_by_extension_with(&bytes, &extension(&full), &p.options())
            .map_err(|e| OpError::Format { path: full.clone(), message: e.to_string() })?
    };
    if image.channels == 1 {
        let data = image.data.iter().flat_map(|&v| [v, v, v]).collect();
        image = crate::values::Image::from_vec(image.width, image.height, 3, data);
    }
    if p.flip_vertical {
        image.flip_vertical_in_place();
    }
    Ok(Value::new(image))
}

/// The image's size from the file's header (or the built-in map's), so that validation can check
/// the sizes that must agree before anything is decoded.
fn size(ctx: &CheckContext, p: LoadHdrParams<Check>) -> Size {
    let (w, h) = match p.path.0.strip_prefix("builtin:") {
        Some(name) => formats::builtin::builtin_size(name)?,
        None => formats::header_size(&resolve_path(ctx.base_dir, &p.path.0), &p.options())?,
    };
    // A header beyond the pixel budget is left to the decoder, whose error names the file.
    let (w, h) = (w as u64, h as u64);
    w.checked_mul(h).is_some_and(|n| n <= crate::engine::op::MAX_PIXELS).then_some((w, h))
}
