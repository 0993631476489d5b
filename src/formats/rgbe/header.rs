//! The RGBE header: magic or signature-less start, `FORMAT=`/`EXPOSURE=`/`PRIMARIES=` lines and
//! the resolution line with its eight layouts (see the [parent module](super)). The decoder
//! reads the pixels from where the header ends.

use super::err;
use crate::formats::FormatError;

/// How the file's scanlines map onto the displayed image (Radiance `resolu.h`: `YMAJOR`,
/// `YDECR`, `XDECR`). Radiance's Y axis points up, so "decreasing Y" (`-Y`) runs top to bottom.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Layout {
    /// `±Y n ±X m`: scanlines are rows (the usual case); otherwise (`±X n ±Y m`) they are columns.
    pub(super) y_major: bool,
    /// `-Y`: Y runs top to bottom in file order (standard); `+Y`: bottom to top.
    pub(super) y_decr: bool,
    /// `-X`: X runs right to left in file order; `+X`: left to right (standard).
    pub(super) x_decr: bool,
}

/// What the header says about the pixel data that follows it.
#[derive(Debug)]
pub(super) struct Header {
    /// Number of scanlines in the file (the resolution line's first number).
    pub(super) scans: usize,
    /// Pixels per scanline (the resolution line's second number).
    pub(super) scanlen: usize,
    pub(super) layout: Layout,
    /// Product of all `EXPOSURE=` values (1 when absent).
    pub(super) exposure: f64,
    /// Offset of the first scanline byte.
    pub(super) data_start: usize,
}

/// The next `\n`-terminated line from `pos` (without the `\n` and a trailing `\r`), advancing
/// `pos` past the `\n`; `None` when no `\n` is left (a truncated header).
fn next_line<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    let rest = bytes.get(*pos..)?;
    let n = rest.iter().position(|&b| b == b'\n')?;
    *pos += n + 1;
    let line = &rest[..n];
    Some(line.strip_suffix(b"\r").unwrap_or(line))
}

/// A short, printable rendering of an untrusted header line for error messages.
fn show(line: &[u8]) -> String {
    let s = String::from_utf8_lossy(&line[..line.len().min(80)]).into_owned();
    format!("{s:?}")
}

/// Whether a header line looks like a resolution line (`-Y 512 +X 1024` and its variants).
fn looks_like_resolution(line: &[u8]) -> bool {
    line.len() >= 3
        && (line[0] == b'-' || line[0] == b'+')
        && (line[1] == b'X' || line[1] == b'Y')
        && line[2].is_ascii_whitespace()
}

impl Header {
    /// The displayed image's (width, height): scanlines are rows for `±Y ±X`, columns otherwise.
    pub(super) fn size(&self) -> (usize, usize) {
        if self.layout.y_major {
            (self.scanlen, self.scans)
        } else {
            (self.scans, self.scanlen)
        }
    }
}

/// Parses the resolution line into (scans, scanlen, layout).
fn parse_resolution(line: &[u8]) -> Result<(usize, usize, Layout), FormatError> {
    let bad = || err(format!("bad resolution line {} (expected e.g. \"-Y 512 +X 1024\")", show(line)));
    let s = std::str::from_utf8(line).map_err(|_| bad())?;
    let t: Vec<&str> = s.split_ascii_whitespace().collect();
    if t.len() != 4 {
        return Err(bad());
    }
    let axis = |tok: &str| -> Result<(bool, u8), FormatError> {
        match tok.as_bytes() {
            [sign @ (b'+' | b'-'), a @ (b'X' | b'Y')] => Ok((*sign == b'+', *a)),
            _ => Err(bad()),
        }
    };
    let (plus1, a1) = axis(t[0])?;
    let (plus2, a2) = axis(t[2])?;
    let n1: usize = t[1].parse().map_err(|_| bad())?;
    let n2: usize = t[3].parse().map_err(|_| bad())?;
    match (a1, a2) {
        // Standard: the outer (scanline) axis is Y. "-Y" = top to bottom, "+Y" = bottom to top;
        // "+X" = left to right, "-X" = right to left.
        (b'Y', b'X') => Ok((n1, n2, Layout { y_major: true, y_decr: !plus1, x_decr: !plus2 })),
        // Transposed: n1 scanlines that are columns (X), each n2 pixels along Y.
        (b'X', b'Y') => Ok((n1, n2, Layout { y_major: false, y_decr: !plus2, x_decr: !plus1 })),
        _ => Err(bad()),
    }
}

/// The `PRIMARIES= rx ry gx gy bx by wx wy` line of a Radiance header, if any (the last one
/// wins; a malformed line is ignored). No line: `None`, read as Rec. 709 (Radiance's own default,
/// 0.640 0.330 0.290 0.600 0.150 0.060 0.333 0.333, differs; most writers mean Rec. 709/sRGB).
pub fn primaries(bytes: &[u8]) -> Option<crate::formats::Primaries> {
    let mut pos = 0;
    next_line(bytes, &mut pos)?;
    let mut found = None;
    while let Some(line) = next_line(bytes, &mut pos) {
        if line.is_empty() || looks_like_resolution(line) {
            break;
        }
        if let Some(v) = line.strip_prefix(b"PRIMARIES=") {
            let v: Vec<f64> = std::str::from_utf8(v)
                .ok()
                .map(|s| s.split_whitespace().filter_map(|t| t.parse().ok()).collect())
                .unwrap_or_default();
            if v.len() == 8 && v.iter().all(|x| x.is_finite()) {
                found = Some(crate::formats::Primaries {
                    red: [v[0], v[1]],
                    green: [v[2], v[3]],
                    blue: [v[4], v[5]],
                    white: [v[6], v[7]],
                });
            }
        }
    }
    found
}

/// The image size a Radiance header declares (`width`, `height`), from the file's first bytes.
pub fn header_size(bytes: &[u8]) -> Result<(usize, usize), FormatError> {
    parse_header(bytes).map(|h| h.size())
}

/// Parses the header. Files starting with `#?RADIANCE` or `#?RGBE` are Radiance files; files
/// without that signature line (Radiance before ~1991, e.g. most of Radiance's own `lib/*.hdr`
/// textures, whose first line is a command such as `oconv ...`) are read the way Radiance's
/// `getheader` reads them, as long as the header is text (no control characters but tab) ending
/// in an empty line and a resolution line; anything else is "not a Radiance file (bad magic)".
pub(super) fn parse_header(bytes: &[u8]) -> Result<Header, FormatError> {
    if bytes.starts_with(b"#?RADIANCE") || bytes.starts_with(b"#?RGBE") {
        parse_header_lines(bytes, true)
    } else {
        parse_header_lines(bytes, false).map_err(|e| err(format!("not a Radiance file (bad magic, and {})", e)))
    }
}

fn parse_header_lines(bytes: &[u8], signed: bool) -> Result<Header, FormatError> {
    let mut pos = 0;
    if signed {
        next_line(bytes, &mut pos).ok_or_else(|| err("truncated header (no end of the first line)"))?;
    }
    let mut exposure = 1.0f64;
    let resolution_line;
    loop {
        let line =
            next_line(bytes, &mut pos).ok_or_else(|| err("truncated header (no empty line and resolution line)"))?;
        if line.is_empty() {
            resolution_line = next_line(bytes, &mut pos).ok_or_else(|| err("truncated header (no resolution line)"))?;
            break;
        }
        if !signed && line.iter().any(|&b| b < b' ' && b != b'\t') {
            return Err(err("a binary header line"));
        }
        // Leniency: a few writers omit the empty line before the resolution line.
        if signed && looks_like_resolution(line) {
            resolution_line = line;
            break;
        }
        if let Some(v) = line.strip_prefix(b"FORMAT=") {
            match v.trim_ascii() {
                b"32-bit_rle_rgbe" => {}
                b"32-bit_rle_xyze" => {
                    return Err(err("unsupported FORMAT=32-bit_rle_xyze (CIE XYZ pixels); only RGBE is read"))
                }
                other => return Err(err(format!("unsupported FORMAT={}", show(other)))),
            }
        } else if let Some(v) = line.strip_prefix(b"EXPOSURE=") {
            // Radiance: "EXPOSURE= a multiplier applied to all pixels; to get the original
            // values divide by the product of all EXPOSURE lines".
            let value: f64 = std::str::from_utf8(v)
                .ok()
                .and_then(|s| s.trim().parse().ok())
                .filter(|x: &f64| x.is_finite() && *x > 0.0)
                .ok_or_else(|| err(format!("bad EXPOSURE line {}", show(line))))?;
            exposure *= value;
        }
        // Anything else (duplicated "#?RADIANCE", comments, GAMMA, PRIMARIES, COLORCORR,
        // SOFTWARE, VIEW, ...) is skipped.
    }
    if !(exposure.is_finite() && exposure > 0.0) {
        return Err(err("EXPOSURE product out of range"));
    }
    let (scans, scanlen, layout) = parse_resolution(resolution_line)?;
    Ok(Header { scans, scanlen, layout, exposure, data_start: pos })
}
