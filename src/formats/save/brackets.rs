//! How `Save` writes a bracket: one photograph per frame, each with its exposure time in EXIF, so
//! that `LoadBrackets` reads the folder back as the same bracket (`formats::photo::encode`).
//!
//! A saver encodes one value as one file (`engine::save::SaveFn`), and a bracket is several
//! files, so `Save` writes the frames itself, as it writes a mip chain's levels ([`save_frames`]),
//! into the paths [`frame_pattern`] gives: `Save(input: "b", path: "frames/")` (a folder: its
//! trailing `/`) writes `frames/frame_0.png`, `frames/frame_1.png`, ... shortest exposure first;
//! a path with `{frame}` chooses the names and the format (`"frames/shot_{frame}.jpg"`: 8-bit
//! JPEG; `.tif`: uncompressed TIFF; `.png`: 8- or 16-bit PNG). `{frame}` is the frame's index in
//! exposure order, zero-padded to one width so that name order is exposure order. The saver
//! registered for the type (reached only when a caller encodes a bracket as one file) writes
//! the shortest exposure. An aligned bracket's coverage masks are not written: a photograph has
//! no place for them (the filled border pixels are saved as they are).

use super::super::photo::encode::encode_frame;
use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::values::{Brackets, BRACKETS};

/// The extensions a bracket's frames are written as.
pub const EXTENSIONS: &[&str] = &["png", "jpg", "jpeg", "tif", "tiff"];

/// Registers the saver of brackets.
pub fn register(r: &mut Registry) {
    r.register_saver(&BRACKETS, EXTENSIONS, save_shortest);
}

fn save_shortest(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let b = value.get::<Brackets>().ok_or("not brackets")?;
    let f = b.frames.first().ok_or("an empty bracket")?;
    encode_frame(b.width, b.height, &f.codes, f.time, &o.ext)
}

/// The path pattern of a bracket's files: a folder (`path` ends in `/`) holds `frame_{frame}.png`;
/// a path with `{frame}` is its own pattern; any other path is `None` (a bracket is not one file).
pub fn frame_pattern(path: &str) -> Option<String> {
    if path.ends_with('/') {
        Some(format!("{path}frame_{{frame}}.png"))
    } else {
        path.contains("{frame}").then(|| path.to_string())
    }
}

/// Every frame as (relative path, bytes), shortest exposure first, the format from the pattern's
/// extension.
pub fn save_frames(b: &Brackets, pattern: &str) -> Result<Vec<(String, Vec<u8>)>, String> {
    let ext = std::path::Path::new(pattern).extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
    let digits = (b.frames.len().saturating_sub(1)).to_string().len();
    b.frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let path = pattern.replace("{frame}", &format!("{k:0digits$}"));
            let bytes =
                encode_frame(b.width, b.height, &f.codes, f.time, &ext).map_err(|e| format!("frame {k}: {e}"))?;
            Ok((path, bytes))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::brackets::{Codes, Frame};

    #[test]
    fn a_folder_gets_one_numbered_png_per_frame_in_exposure_order() {
        assert_eq!(frame_pattern("out/frames/").as_deref(), Some("out/frames/frame_{frame}.png"));
        assert_eq!(frame_pattern("a/s_{frame}.jpg").as_deref(), Some("a/s_{frame}.jpg"));
        assert_eq!(frame_pattern("a/one.png"), None);
        let frame =
            |t: f64, v: u8| Frame { name: format!("{t}"), time: t, codes: Codes::U8(vec![v; 6]), covered: None };
        let frames = (0..11).map(|k| frame(1.0 / (1 << k) as f64, k as u8)).collect();
        let b = Brackets::new(2, 1, 8, frames).unwrap();
        let files = save_frames(&b, "f/frame_{frame}.png").unwrap();
        assert_eq!(files.len(), 11);
        assert_eq!((files[0].0.as_str(), files[10].0.as_str()), ("f/frame_00.png", "f/frame_10.png"));
        let first = crate::formats::photo::decode(&files[0].1).unwrap();
        assert_eq!(first.exif.exposure_time, Some(1.0 / 1024.0));
        assert_eq!(first.codes, Codes::U8(vec![10; 6]));
        let o = SaveOptions::new("tif");
        let one = save_shortest(&Value::new(b), &o).unwrap();
        assert_eq!(crate::formats::photo::decode(&one).unwrap().exif.exposure_time, Some(1.0 / 1024.0));
    }
}
