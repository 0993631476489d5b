//! Radiance RGBE (`.hdr`, `.pic`): a hand-written reader and writer.
//!
//! Why one file of about 450 code lines: header, resolution line, the three scanline encodings
//! and the writer are one format whose parts refer to each other (the writer emits what the
//! reader's fast path expects); the long comment below is the format's description, not code.
//!
//! Hand-written (rather than `image::codecs::hdr`) for speed: it decodes straight from the byte
//! slice into the final f32 buffer through a 256-entry exponent table, with no per-byte `Read`
//! calls; it is benchmarked against the `image` crate's decoder and must match it bit for bit.
//!
//! # The format (Greg Ward, *Graphics Gems II* "Real Pixels" 1991; Radiance `color.c`/`header.c`)
//!
//! ```text
//! #?RADIANCE                      magic ("#?RGBE" also occurs); first line
//! # any comment                   header lines, one per '\n', until an empty line
//! FORMAT=32-bit_rle_rgbe          (32-bit_rle_xyze = CIE XYZ primaries: refused here)
//! EXPOSURE=2.0                    pixel values were multiplied by this: divide (product of all lines)
//! GAMMA=1, PRIMARIES=..., ...     other lines: skipped
//!                                 <- empty line ends the header
//! -Y 512 +X 1024                  resolution line, then the scanlines
//! ```
//!
//! Resolution line (Radiance `resolu.h`): `-Y H +X W` is the standard order (first scanline is
//! the top row, pixels left to right). `+Y` means the first scanline is the *bottom* row (flipped
//! here), `-X` means pixels run right to left (mirrored here). `±X W ±Y H` (W scanlines that are
//! *columns*, each H pixels along Y; `+X` = first column at the left, `-Y` = each column top to
//! bottom) is transposed here. All eight layouts come out as displayed, where Radiance's
//! `pix2loc` (`src/common/image.c`) puts each pixel (`tests/radiance_conformance.rs` checks them
//! against it). OpenImageIO 3.2 agrees except for `+X +Y` and `-X -Y`, which it tags as EXIF
//! `Orientation` 6 and 8 where Radiance's definition is 8 and 6 (its image is rotated 180 degrees).
//!
//! Signature: `#?RADIANCE` (or `#?RGBE`) on the first line. Radiance does not require it, and
//! files written before ~1991 (many of Radiance's own `lib/*.hdr` textures) start straight with a
//! command line; they are read when the header is text ending in an empty line and a resolution
//! line (otherwise: "not a Radiance file (bad magic, ...)"). A missing `FORMAT=` line means RGBE,
//! as in Radiance (OpenImageIO refuses such files).
//!
//! A pixel is 4 bytes R, G, B, E (shared exponent). Decoding constant: we use
//! `c * 2^(E - 136)` (E = 0 -> 0.0), the convention of stb_image, OpenCV and the `image` crate;
//! Radiance's own `colr_color` uses `(c + 0.5) * 2^(E - 136)`. Both are "correct"
//! (`../shared/data/envmaps/SOURCES.md`, "Format pitfalls"); we pick the first so that we agree
//! exactly with the `image` crate and OpenCV, and our tests' tolerances are set to it.
//!
//! Scanline encodings (Radiance `color.c`, `freadcolrs`/`oldreadcolrs`):
//! - **new-style adaptive RLE** (every real file in `../shared/data/envmaps`): only for
//!   8 <= W <= 32767; the scanline starts with `02 02 hi lo` (hi < 128, `hi << 8 | lo == W`), then
//!   the four channel planes R, G, B, E one after the other, each a sequence of packets:
//!   count > 128 = a run of `count - 128` copies of the next byte; 1..=128 = `count` literal bytes;
//!   0 is invalid.
//! - **flat**: W pixels of 4 bytes (used for W < 8 or W > 32767, or when the `02 02` marker is
//!   absent), possibly with the
//! - **old RLE repeat code** `1 1 1 n`: repeat the previous pixel `n << shift` times, where `shift`
//!   starts at 0 and grows by 8 for each *consecutive* repeat code (so `1 1 1 43, 1 1 1 1` repeats
//!   43 + 256 times). A repeat code as the first pixel of a scanline has no previous pixel and is
//!   an error here, as in the `image` crate (Radiance's current `freadcolrs` takes those first
//!   4 bytes as a literal pixel; no file we know of has one).
//!
//! # Hostile input
//!
//! Width or height 0, more than [`MAX_PIXELS`] pixels, fewer bytes than the smallest possible
//! encoding of the claimed size (`H * min(4 W, 8)`: a flat row needs 4 W bytes, any RLE row at
//! least 8), runs or literals past the end of a row, count 0, truncation: all give a
//! [`FormatError`] naming the scanline. The output grows row by row, so a truncated file fails
//! before it has allocated more than what it actually decoded. No panics, no unchecked indexing.
//!
//! # Writer
//!
//! [`encode`] writes `-Y H +X W` with new-style RLE for 8 <= W <= 32767, flat otherwise, with the
//! standard frexp conversion (Radiance `setcolr`, stb `stbiw__linear_to_rgbe`): v = max channel;
//! v < 1e-32 -> `0 0 0 0`; else v = m 2^e with m in [0.5, 1), scale = m 256 / v, each byte
//! `(c * scale) as u8`, E = e + 128. The largest channel byte is then always >= 128, so a written
//! pixel can never look like a `1 1 1 n` repeat code or a `02 02` RLE marker. Relative error per
//! channel: < 1/128 of the pixel's largest channel (truncation, not rounding, as in Radiance).
//! Negative and NaN -> 0; +Inf and anything above the largest RGBE value (255 * 2^119) -> that
//! largest value.

use rayon::prelude::*;

use super::{FormatError, MAX_PIXELS};
use crate::values::Image;

fn err(msg: impl Into<String>) -> FormatError {
    FormatError::Invalid(msg.into())
}

/// The largest value an RGBE pixel can hold: mantissa byte 255, exponent byte 255 -> 255 * 2^119.
fn max_rgbe_value() -> f64 {
    255.0 * 2f64.powi(119)
}

/// `table[e] = 2^(e - 136) / exposure` for e = 1..=255, `table[0] = 0`.
///
/// Why a table: one lookup and three multiplies per pixel instead of an `exp2`/`ldexp` per pixel.
/// With `exposure == 1` every entry is an exact power of two (2^-135 is a subnormal f32, still
/// exact), so `c as f32 * table[e]` is exactly the `image` crate's result.
fn exponent_table(exposure: f64) -> [f32; 256] {
    let mut t = [0f32; 256];
    for (e, slot) in t.iter_mut().enumerate().skip(1) {
        let p = 2f64.powi(e as i32 - 136);
        // Clamped so that 255 * table[e] stays a finite f32 whatever EXPOSURE says (a tiny
        // EXPOSURE would otherwise give +Inf, and 0 * Inf = NaN for zero mantissas).
        *slot = if exposure == 1.0 { p as f32 } else { (p / exposure).min(f32::MAX as f64 / 256.0) as f32 };
    }
    t
}

/// How the file's scanlines map onto the displayed image (Radiance `resolu.h`: `YMAJOR`,
/// `YDECR`, `XDECR`). Radiance's Y axis points up, so "decreasing Y" (`-Y`) runs top to bottom.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    /// `±Y n ±X m`: scanlines are rows (the usual case); otherwise (`±X n ±Y m`) they are columns.
    y_major: bool,
    /// `-Y`: Y runs top to bottom in file order (standard); `+Y`: bottom to top.
    y_decr: bool,
    /// `-X`: X runs right to left in file order; `+X`: left to right (standard).
    x_decr: bool,
}

/// What the header says about the pixel data that follows it.
#[derive(Debug)]
struct Header {
    /// Number of scanlines in the file (the resolution line's first number).
    scans: usize,
    /// Pixels per scanline (the resolution line's second number).
    scanlen: usize,
    layout: Layout,
    /// Product of all `EXPOSURE=` values (1 when absent).
    exposure: f64,
    /// Offset of the first scanline byte.
    data_start: usize,
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
    fn size(&self) -> (usize, usize) {
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
pub fn primaries(bytes: &[u8]) -> Option<super::Primaries> {
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
                found = Some(super::Primaries {
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
fn parse_header(bytes: &[u8]) -> Result<Header, FormatError> {
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

/// Reads 4 bytes at `pos`, advancing it.
#[inline]
fn read4(data: &[u8], pos: &mut usize) -> Option<[u8; 4]> {
    let s = data.get(*pos..pos.checked_add(4)?)?;
    *pos += 4;
    Some([s[0], s[1], s[2], s[3]])
}

#[inline]
fn rgbe_to_f32(p: [u8; 4], table: &[f32; 256]) -> [f32; 3] {
    let f = table[p[3] as usize];
    [p[0] as f32 * f, p[1] as f32 * f, p[2] as f32 * f]
}

fn truncated(y: usize) -> FormatError {
    err(format!("truncated pixel data in scanline {y}"))
}

/// Decodes the four channel planes of a new-style RLE scanline into `planes` (4 * w bytes).
fn decode_rle_planes(data: &[u8], pos: &mut usize, planes: &mut [u8], w: usize, y: usize) -> Result<(), FormatError> {
    const NAMES: [&str; 4] = ["R", "G", "B", "E"];
    for (c, plane) in planes.chunks_exact_mut(w).take(4).enumerate() {
        let mut x = 0usize;
        while x < w {
            let count = *data.get(*pos).ok_or_else(|| truncated(y))? as usize;
            *pos += 1;
            if count > 128 {
                let n = count - 128;
                if n > w - x {
                    return Err(err(format!(
                        "scanline {y}: RLE run of {n} in channel {} goes past the end of the row ({x} + {n} > {w})",
                        NAMES[c]
                    )));
                }
                let v = *data.get(*pos).ok_or_else(|| truncated(y))?;
                *pos += 1;
                plane[x..x + n].fill(v);
                x += n;
            } else if count == 0 {
                return Err(err(format!("scanline {y}: RLE count 0 in channel {} at x = {x}", NAMES[c])));
            } else {
                let n = count;
                if n > w - x {
                    return Err(err(format!(
                        "scanline {y}: RLE literal of {n} in channel {} goes past the end of the row ({x} + {n} > {w})",
                        NAMES[c]
                    )));
                }
                let src = data.get(*pos..*pos + n).ok_or_else(|| truncated(y))?;
                plane[x..x + n].copy_from_slice(src);
                *pos += n;
                x += n;
            }
        }
    }
    Ok(())
}

/// Converts planar RGBE (R plane, G plane, B plane, E plane) to interleaved f32 RGB.
fn convert_planes(planes: &[u8], row: &mut [f32], w: usize, table: &[f32; 256], mirror: bool) {
    let (r, rest) = planes.split_at(w);
    let (g, rest) = rest.split_at(w);
    let (b, e) = rest.split_at(w);
    let src = r.iter().zip(g).zip(b).zip(e);
    if mirror {
        for (px, (((&r, &g), &b), &e)) in row.chunks_exact_mut(3).rev().zip(src) {
            put_rgbe(px, r, g, b, e, table);
        }
    } else {
        for (px, (((&r, &g), &b), &e)) in row.chunks_exact_mut(3).zip(src) {
            put_rgbe(px, r, g, b, e, table);
        }
    }
}

#[inline(always)]
fn put_rgbe(px: &mut [f32], r: u8, g: u8, b: u8, e: u8, table: &[f32; 256]) {
    let f = table[e as usize];
    px[0] = r as f32 * f;
    px[1] = g as f32 * f;
    px[2] = b as f32 * f;
}

/// Decodes a flat scanline (with optional old-style `1 1 1 n` repeat codes) whose first pixel,
/// `first`, has already been read, straight into the f32 row.
#[allow(clippy::too_many_arguments)]
fn decode_flat_row(
    data: &[u8],
    pos: &mut usize,
    first: [u8; 4],
    row: &mut [f32],
    w: usize,
    table: &[f32; 256],
    mirror: bool,
    y: usize,
) -> Result<(), FormatError> {
    // Output index of pixel x (mirrored for "-X").
    let at = |x: usize| if mirror { w - 1 - x } else { x };
    // (The `image` crate refuses this too, whatever the width.)
    if first[0] == 1 && first[1] == 1 && first[2] == 1 {
        return Err(err(format!("scanline {y}: old-style repeat code at the start of a scanline")));
    }
    let mut prev = rgbe_to_f32(first, table);
    let i = 3 * at(0);
    row[i..i + 3].copy_from_slice(&prev);
    let mut x = 1usize;
    let mut shift = 0u32;
    while x < w {
        let p = read4(data, pos).ok_or_else(|| truncated(y))?;
        if p[0] == 1 && p[1] == 1 && p[2] == 1 {
            // Old RLE: repeat the previous pixel (n << shift) times; consecutive codes are
            // successively more significant base-256 digits of the count.
            let n: u64 = if shift < 56 {
                (p[3] as u64) << shift
            } else if p[3] == 0 {
                0
            } else {
                u64::MAX
            };
            shift = shift.saturating_add(8);
            if n > (w - x) as u64 {
                return Err(err(format!(
                    "scanline {y}: old-style repeat of {n} pixels goes past the end of the row ({x} + {n} > {w})"
                )));
            }
            let n = n as usize;
            if mirror {
                // Pixels x..x+n land at w-x-n..w-x (reversed, but all equal).
                for px in row[3 * (w - x - n)..3 * (w - x)].chunks_exact_mut(3) {
                    px.copy_from_slice(&prev);
                }
            } else {
                for px in row[3 * x..3 * (x + n)].chunks_exact_mut(3) {
                    px.copy_from_slice(&prev);
                }
            }
            x += n;
        } else {
            shift = 0;
            prev = rgbe_to_f32(p, table);
            let i = 3 * at(x);
            row[i..i + 3].copy_from_slice(&prev);
            x += 1;
        }
    }
    Ok(())
}

/// Decodes a Radiance RGBE file (see the module docs for the format and the conventions).
///
/// Returns a 3-channel image, row 0 at the top (after honouring the `+Y` / `-X` / transposed
/// layouts), values
/// `c * 2^(E-136)` divided by the product of the header's `EXPOSURE` values.
pub fn decode(bytes: &[u8]) -> Result<Image, FormatError> {
    let hd = parse_header(bytes)?;
    // In file order: h scanlines of w pixels (rows, or columns for transposed layouts).
    let (w, h) = (hd.scanlen, hd.scans);
    // "-X" with row scanlines is mirrored while decoding; the other flips are applied after.
    let mirror = hd.layout.y_major && hd.layout.x_decr;
    if w == 0 || h == 0 {
        return Err(err(format!("empty image: header claims {w}x{h} pixels")));
    }
    let pixels = w
        .checked_mul(h)
        .filter(|&p| p <= MAX_PIXELS)
        .ok_or_else(|| err(format!("image too large: {w}x{h} pixels (limit {MAX_PIXELS})")))?;
    let data = bytes.get(hd.data_start..).unwrap_or(&[]);
    // Smallest possible encoding: a flat row needs 4 W bytes; any RLE row (new style: 4 + 4 * 2
    // bytes; old style: one pixel + one repeat code) at least 8. w, h <= 2^28: no overflow.
    let min_bytes = h * (4 * w).min(8);
    if data.len() < min_bytes {
        return Err(err(format!("truncated: header claims {w}x{h} pixels but only {} bytes follow", data.len())));
    }
    let table = exponent_table(hd.exposure);
    let rle_width = (8..=32767).contains(&w);
    // Reserve no more than the data could plausibly expand to (new-style RLE of a constant image
    // reaches ~16 pixels per byte); beyond that the buffer grows row by row.
    let mut out: Vec<f32> = Vec::with_capacity(pixels.min(data.len().saturating_mul(16)) * 3);
    let mut planes = vec![0u8; if rle_width { 4 * w } else { 0 }];
    let mut pos = 0usize;
    let row_len = 3 * w;
    for y in 0..h {
        // A row is allocated only once the data could hold it. New-style RLE rows (widths
        // 8..=32767) are small; a wider or flat row needs 4 bytes a pixel, and even the old
        // `1 1 1 n` repeat code cannot plausibly expand a few bytes into a 2^28-pixel row: rows
        // claiming more than 256 pixels per remaining byte are refused as truncated.
        if !rle_width && (data.len() - pos.min(data.len())).saturating_mul(256) < w {
            return Err(truncated(y));
        }
        let first = read4(data, &mut pos).ok_or_else(|| truncated(y))?;
        let base = out.len();
        out.resize(base + row_len, 0.0);
        let row = &mut out[base..];
        if rle_width && first[0] == 2 && first[1] == 2 && first[2] & 0x80 == 0 {
            let encoded = ((first[2] as usize) << 8) | first[3] as usize;
            if encoded != w {
                return Err(err(format!(
                    "scanline {y}: RLE scanline length {encoded} does not match the image width {w}"
                )));
            }
            decode_rle_planes(data, &mut pos, &mut planes, w, y)?;
            convert_planes(&planes, row, w, &table, mirror);
        } else {
            decode_flat_row(data, &mut pos, first, row, w, &table, mirror, y)?;
        }
    }
    let Layout { y_major, y_decr, x_decr } = hd.layout;
    if !y_major {
        return Ok(transpose_columns(&out, h, w, y_decr, x_decr));
    }
    if !y_decr {
        for y in 0..h / 2 {
            let (top, bottom) = out.split_at_mut((h - 1 - y) * row_len);
            top[y * row_len..(y + 1) * row_len].swap_with_slice(&mut bottom[..row_len]);
        }
    }
    Ok(Image::from_vec(w, h, 3, out))
}

/// The displayed image of a transposed file (`±X n ±Y m`): `grid` holds `n` scanlines (columns,
/// in X order: left to right for `+X`) of `m` pixels each (in Y order: top to bottom for `-Y`).
fn transpose_columns(grid: &[f32], n: usize, m: usize, y_decr: bool, x_decr: bool) -> Image {
    let (w, h) = (n, m);
    let mut out = vec![0f32; grid.len()];
    for (i, column) in grid.chunks_exact(3 * m).enumerate() {
        let x = if x_decr { w - 1 - i } else { i };
        for (j, px) in column.chunks_exact(3).enumerate() {
            let y = if y_decr { j } else { h - 1 - j };
            out[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(px);
        }
    }
    Image::from_vec(w, h, 3, out)
}

/// Standard float -> RGBE conversion (see the module docs). Inputs are cleaned first:
/// negative/NaN -> 0, +Inf or too large -> the largest RGBE value.
#[inline]
fn to_rgbe(rgb: [f32; 3], max_value: f64) -> [u8; 4] {
    let clean = |c: f32| -> f64 {
        if c > 0.0 {
            (c as f64).min(max_value)
        } else {
            0.0
        }
    };
    let (r, g, b) = (clean(rgb[0]), clean(rgb[1]), clean(rgb[2]));
    let v = r.max(g).max(b);
    if v < 1e-32 {
        return [0, 0, 0, 0];
    }
    // frexp: v is a normal f64 in [1e-32, 255 * 2^119], so its biased exponent field is exact.
    let bits = v.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1022;
    let m = f64::from_bits((bits & !(0x7ffu64 << 52)) | (1022u64 << 52)); // in [0.5, 1)
    let scale = m * 256.0 / v;
    // e <= 127 (v < 2^127) and e >= -106 (v >= 1e-32): e + 128 is in 22..=255.
    [(r * scale) as u8, (g * scale) as u8, (b * scale) as u8, (e + 128) as u8]
}

/// Pixel x of a row with `c` channels as RGB (grey for 1 channel); missing samples read as 0.
#[inline]
fn pixel_rgb(row: &[f32], c: usize, x: usize) -> [f32; 3] {
    let g = |i: usize| row.get(x * c + i).copied().unwrap_or(0.0);
    if c >= 3 {
        [g(0), g(1), g(2)]
    } else {
        let v = g(0);
        [v, v, v]
    }
}

/// Appends the new-style RLE encoding of one channel plane (Radiance `fwritecolrs`): runs of at
/// least 4 equal bytes (up to 127) as `128 + n, byte`, everything else as literals of up to 128.
fn rle_plane(p: &[u8], out: &mut Vec<u8>) {
    const MIN_RUN: usize = 4;
    let n = p.len();
    let run_len = |i: usize, cap: usize| -> usize {
        let v = p[i];
        let mut k = 1;
        while k < cap && i + k < n && p[i + k] == v {
            k += 1;
        }
        k
    };
    let mut i = 0;
    while i < n {
        let run = run_len(i, 127);
        if run >= MIN_RUN {
            out.push(128 + run as u8);
            out.push(p[i]);
            i += run;
            continue;
        }
        let start = i;
        i += 1;
        while i < n && i - start < 128 && run_len(i, MIN_RUN) < MIN_RUN {
            i += 1;
        }
        out.push((i - start) as u8);
        out.extend_from_slice(&p[start..i]);
    }
}

fn encode_row(image: &Image, y: usize, rle: bool, max_value: f64) -> Vec<u8> {
    let (w, c) = (image.width, image.channels);
    let row: &[f32] = if c == 0 { &[] } else { image.data.get(y * w * c..(y + 1) * w * c).unwrap_or(&[]) };
    if rle {
        let mut planes = vec![0u8; 4 * w];
        for x in 0..w {
            let p = to_rgbe(pixel_rgb(row, c, x), max_value);
            for (k, &byte) in p.iter().enumerate() {
                planes[k * w + x] = byte;
            }
        }
        let mut out = Vec::with_capacity(4 + 4 * w + 4 * w / 64 + 8);
        out.extend_from_slice(&[2, 2, (w >> 8) as u8, (w & 0xff) as u8]);
        for plane in planes.chunks_exact(w) {
            rle_plane(plane, &mut out);
        }
        out
    } else {
        let mut out = Vec::with_capacity(4 * w);
        for x in 0..w {
            out.extend_from_slice(&to_rgbe(pixel_rgb(row, c, x), max_value));
        }
        out
    }
}

/// Encodes `image` as a Radiance RGBE file, `-Y H +X W` (row 0 at the top), new-style RLE for
/// widths 8..=32767 and flat scanlines otherwise. 1-channel images are written grey.
/// Rows are encoded in parallel (rayon), a block of rows at a time, and concatenated (so the
/// encoded rows of a 16384 x 8192 map are not held twice).
pub fn encode(image: &Image) -> Vec<u8> {
    const BLOCK_ROWS: usize = 256;
    let (w, h) = (image.width, image.height);
    let mut out = format!("#?RADIANCE\n# Written by hdrflow\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    let rle = (8..=32767).contains(&w);
    let max_value = max_rgbe_value();
    for first in (0..h).step_by(BLOCK_ROWS) {
        let block = first..(first + BLOCK_ROWS).min(h);
        let rows: Vec<Vec<u8>> = block.into_par_iter().map(|y| encode_row(image, y, rle, max_value)).collect();
        for r in rows {
            out.extend_from_slice(&r);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64*: deterministic test data without a dependency.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        fn unit(&mut self) -> f64 {
            (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn random_image(w: usize, h: usize, seed: u64) -> Image {
        let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
        let data =
            (0..w * h * 3)
                .map(|_| {
                    if rng.unit() < 0.1 {
                        0.0
                    } else {
                        (2f64.powf(rng.unit() * 60.0 - 30.0) * (0.5 + rng.unit())) as f32
                    }
                })
                .collect();
        Image::from_vec(w, h, 3, data)
    }

    fn assert_close_rgbe(a: &Image, b: &Image) {
        assert_eq!((a.width, a.height, b.channels), (b.width, b.height, 3));
        for y in 0..a.height {
            for x in 0..a.width {
                let p = a.rgb(x, y);
                let q = b.rgb(x, y);
                let v = p[0].max(p[1]).max(p[2]) as f64;
                for k in 0..3 {
                    let e = (p[k] as f64 - q[k] as f64).abs();
                    assert!(e <= v / 128.0 * (1.0 + 1e-6) + 1e-30, "({x},{y})[{k}]: {} vs {}", p[k], q[k]);
                }
            }
        }
    }

    fn header(res: &str) -> Vec<u8> {
        format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes()
    }

    #[test]
    fn round_trip_various_widths() {
        for (i, &(w, h)) in [(1usize, 3usize), (7, 4), (8, 3), (300, 5), (40000, 1), (37, 2)].iter().enumerate() {
            let img = random_image(w, h, i as u64 + 1);
            let bytes = encode(&img);
            let back = decode(&bytes).unwrap_or_else(|e| panic!("{w}x{h}: {e}"));
            assert_close_rgbe(&img, &back);
        }
    }

    #[test]
    fn rle_compresses_constant_rows_and_round_trips() {
        let img = Image::from_vec(1000, 2, 3, vec![0.75; 6000]);
        let bytes = encode(&img);
        // Header ~70 bytes + per row 4 + 4 planes x 8 runs of 127 x 2 bytes = 68.
        assert!(bytes.len() < 250, "{}", bytes.len());
        let back = decode(&bytes).unwrap();
        assert!(back.data.iter().all(|&v| v == 0.75));
    }

    #[test]
    fn re_encoding_is_lossless() {
        let img = random_image(64, 8, 99);
        let once = decode(&encode(&img)).unwrap();
        let twice = decode(&encode(&once)).unwrap();
        assert_eq!(once, twice);
    }

    #[test]
    fn special_values_and_grey() {
        let img = Image::from_vec(
            4,
            1,
            3,
            vec![
                f32::NAN,
                -1.0,
                1.0, //
                f32::INFINITY,
                0.0,
                0.0, //
                1e-40,
                0.0,
                0.0, //
                -0.0,
                2.0,
                4.0,
            ],
        );
        let back = decode(&encode(&img)).unwrap();
        assert_eq!(&back.data[0..3], &[0.0, 0.0, 1.0]);
        assert_eq!(back.data[3] as f64, max_rgbe_value());
        assert_eq!(&back.data[6..9], &[0.0, 0.0, 0.0]);
        assert_eq!(&back.data[9..12], &[0.0, 2.0, 4.0]);

        let grey = Image::from_vec(3, 1, 1, vec![0.5, 1.0, 8.0]);
        let back = decode(&encode(&grey)).unwrap();
        assert_eq!(back.channels, 3);
        assert_eq!(back.data, vec![0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 8.0, 8.0, 8.0]);
    }

    #[test]
    fn hand_written_flat_scanlines() {
        // 3x2, flat: E = 129 -> 2^(129-136) = 1/128, so byte 128 -> 1.0, 64 -> 0.5, 32 -> 0.25.
        let mut f = header("-Y 2 +X 3");
        for _ in 0..3 {
            f.extend_from_slice(&[128, 64, 32, 129]);
        }
        f.extend_from_slice(&[0, 0, 0, 0, 255, 255, 255, 136, 1, 2, 3, 0]);
        let img = decode(&f).unwrap();
        assert_eq!((img.width, img.height, img.channels), (3, 2, 3));
        assert_eq!(img.rgb(2, 0), [1.0, 0.5, 0.25]);
        assert_eq!(img.rgb(0, 1), [0.0, 0.0, 0.0]);
        assert_eq!(img.rgb(1, 1), [255.0, 255.0, 255.0]);
        assert_eq!(img.rgb(2, 1), [0.0, 0.0, 0.0]); // E = 0 -> 0 whatever the mantissas
    }

    #[test]
    fn old_style_repeat_codes() {
        // Width 10: one pixel then "repeat 9".
        let mut f = header("-Y 1 +X 10");
        f.extend_from_slice(&[128, 0, 0, 129, 1, 1, 1, 9]);
        let img = decode(&f).unwrap();
        for x in 0..10 {
            assert_eq!(img.rgb(x, 0), [1.0, 0.0, 0.0]);
        }
        // Width 302: pixel, repeat 43, repeat 1 << 8 (consecutive: shift 8) = 300 pixels, then
        // a new pixel, then "repeat 1" (shift back to 0).
        let mut f = header("-Y 1 +X 302");
        f.extend_from_slice(&[64, 64, 64, 129, 1, 1, 1, 43, 1, 1, 1, 1, 128, 0, 0, 130, 1, 1, 1, 1]);
        let img = decode(&f).unwrap();
        for x in 0..300 {
            assert_eq!(img.rgb(x, 0), [0.5, 0.5, 0.5], "x = {x}");
        }
        assert_eq!(img.rgb(300, 0), [2.0, 0.0, 0.0]);
        assert_eq!(img.rgb(301, 0), [2.0, 0.0, 0.0]);
        // A repeat past the end of the row is an error naming the scanline.
        let mut f = header("-Y 1 +X 10");
        f.extend_from_slice(&[128, 0, 0, 129, 1, 1, 1, 10]);
        let e = decode(&f).unwrap_err().to_string();
        assert!(e.contains("scanline 0") && e.contains("past the end"), "{e}");
        // A repeat code first in a scanline has no previous pixel.
        let mut f = header("-Y 1 +X 10");
        f.extend_from_slice(&[1, 1, 1, 9, 0, 0, 0, 0]);
        let e = decode(&f).unwrap_err().to_string();
        assert_eq!(e, "scanline 0: old-style repeat code at the start of a scanline");
    }

    #[test]
    fn messy_header_and_exposure() {
        let mut f = b"#?RADIANCE\n#?RADIANCE\n# Made with something\nGAMMA=1\nPRIMARIES=0 0 0 0 0 0 0 0\n\
EXPOSURE=2\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n"
            .to_vec();
        f.extend_from_slice(&[128, 128, 128, 129, 64, 0, 32, 129]);
        let img = decode(&f).unwrap();
        assert_eq!(img.data, vec![0.5, 0.5, 0.5, 0.25, 0.0, 0.125]);
        // Two EXPOSURE lines multiply: 2 * 4 = 8.
        let mut f = b"#?RGBE\nEXPOSURE=2\nEXPOSURE= 4.0\r\n\r\n-Y 1 +X 1\r\n".to_vec();
        f.extend_from_slice(&[128, 128, 128, 129]);
        assert_eq!(decode(&f).unwrap().data, vec![0.125, 0.125, 0.125]);
    }

    #[test]
    fn xyze_and_bad_format_refused() {
        let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n".to_vec();
        f.extend_from_slice(&[1, 2, 3, 4]);
        assert!(decode(&f).unwrap_err().to_string().contains("xyze"));
    }

    #[test]
    fn orientations() {
        // 2x2: file pixels in file order a, b / c, d with values 1, 2 / 3, 4 (E = 129 -> /128).
        let px = |v: u8| [v * 32, v * 32, v * 32, 129];
        let body: Vec<u8> = [1u8, 2, 3, 4].iter().flat_map(|&v| px(v)).collect();
        let grey = |img: &Image| -> Vec<f32> { img.data.chunks(3).map(|p| p[0]).collect() };
        for (res, want) in [
            ("-Y 2 +X 2", vec![0.25, 0.5, 0.75, 1.0]),
            ("+Y 2 +X 2", vec![0.75, 1.0, 0.25, 0.5]),
            ("-Y 2 -X 2", vec![0.5, 0.25, 1.0, 0.75]),
            ("+Y 2 -X 2", vec![1.0, 0.75, 0.5, 0.25]),
        ] {
            let mut f = header(res);
            f.extend_from_slice(&body);
            assert_eq!(grey(&decode(&f).unwrap()), want, "{res}");
        }
        // +Y with an odd height and RLE rows.
        let img = random_image(9, 3, 5);
        let bytes = encode(&img);
        let flipped_file = {
            let at = bytes.windows(9).position(|w| w == b"-Y 3 +X 9").unwrap();
            let mut f = bytes.clone();
            f[at] = b'+';
            f
        };
        let a = decode(&bytes).unwrap();
        let b = decode(&flipped_file).unwrap();
        assert_eq!(a.flipped_vertical(), b);
        // Transposed layouts: 3 scanlines (columns) of 2 pixels, file order 1..6.
        let body: Vec<u8> = (1u8..=6).flat_map(px).collect();
        for (res, want) in [
            ("+X 3 -Y 2", [1, 3, 5, 2, 4, 6]),
            ("-X 3 -Y 2", [5, 3, 1, 6, 4, 2]),
            ("+X 3 +Y 2", [2, 4, 6, 1, 3, 5]),
            ("-X 3 +Y 2", [6, 4, 2, 5, 3, 1]),
        ] {
            let mut f = header(res);
            f.extend_from_slice(&body);
            let img = decode(&f).unwrap_or_else(|e| panic!("{res}: {e}"));
            assert_eq!((img.width, img.height), (3, 2), "{res}");
            assert_eq!(header_size(&f).unwrap(), (3, 2), "{res}");
            assert_eq!(grey(&img), want.map(|v| v as f32 / 4.0).to_vec(), "{res}");
        }
        // A transposed RLE file (scanlines of 9 pixels) is the standard one transposed.
        let bytes = encode(&random_image(9, 4, 6));
        let img = decode(&bytes).unwrap();
        let at = bytes.windows(9).position(|w| w == b"-Y 4 +X 9").unwrap();
        let mut f = bytes.clone();
        f[at..at + 9].copy_from_slice(b"+X 4 -Y 9");
        let t = decode(&f).unwrap();
        assert_eq!((t.width, t.height), (4, 9));
        for y in 0..4 {
            for x in 0..9 {
                assert_eq!(t.rgb(y, x), img.rgb(x, y));
            }
        }
    }

    #[test]
    fn files_without_the_signature_line() {
        // Radiance before ~1991: no "#?RADIANCE", the header starts with a command line.
        let mut f = b"oconv -f scene.rad\n\tpfilt -x /2\nEXPOSURE=2\n\n-Y 1 +X 2\n".to_vec();
        f.extend_from_slice(&[128, 128, 128, 129, 64, 0, 32, 129]);
        assert_eq!(decode(&f).unwrap().data, vec![0.5, 0.5, 0.5, 0.25, 0.0, 0.125]);
        assert_eq!(header_size(&f).unwrap(), (2, 1));
        // Without the signature, a header that is not text ending in a resolution line is not a
        // Radiance file.
        for bad in
            [&b"oconv\n\x01\x02\n\n-Y 1 +X 1\n\x80\x80\x80\x81"[..], b"hello\n\nworld\n1234", b"\x89PNG\r\n\x1a\n"]
        {
            let e = decode(bad).unwrap_err().to_string();
            assert!(e.starts_with("not a Radiance file (bad magic"), "{e}");
        }
    }

    #[test]
    fn bad_magic() {
        let e = decode(b"P6\n1 1\n255\n\0\0\0").unwrap_err().to_string();
        assert!(e.starts_with("not a Radiance file (bad magic"), "{e}");
        let e = decode(b"").unwrap_err().to_string();
        assert!(e.starts_with("not a Radiance file (bad magic"), "{e}");
    }

    #[test]
    fn truncation_never_panics() {
        let bytes = encode(&random_image(20, 3, 7));
        for n in 0..bytes.len() {
            let e = decode(&bytes[..n]).unwrap_err().to_string();
            assert!(e.contains("truncated"), "prefix of {n} bytes: {e}");
        }
        let flat = encode(&random_image(5, 3, 8));
        for n in 0..flat.len() {
            let e = decode(&flat[..n]).unwrap_err().to_string();
            assert!(e.contains("truncated"), "prefix of {n} bytes: {e}");
        }
    }

    #[test]
    fn garbage_after_a_valid_header_never_panics() {
        let mut rng = Rng(12345);
        for &(w, h) in &[(1usize, 1usize), (8, 2), (10, 3), (40, 2)] {
            for _ in 0..200 {
                let mut f = header(&format!("-Y {h} +X {w}"));
                let n = (rng.next() % 400) as usize;
                for i in 0..n {
                    // Bias toward the interesting bytes (RLE markers and repeat codes).
                    let b = match rng.next() % 4 {
                        0 => [1u8, 2, 128, 255][(rng.next() % 4) as usize],
                        _ => rng.next() as u8,
                    };
                    f.push(if i < 2 && w >= 8 && rng.next().is_multiple_of(2) { 2 } else { b });
                }
                let _ = decode(&f);
            }
        }
    }

    #[test]
    fn huge_header_fails_fast() {
        let mut f = header("-Y 200000 +X 200000");
        f.extend_from_slice(&[0u8; 100]);
        let t = std::time::Instant::now();
        let e = decode(&f).unwrap_err().to_string();
        assert_eq!(e, "image too large: 200000x200000 pixels (limit 268435456)");
        // Within MAX_PIXELS but far more than 100 bytes could encode: the lower bound catches it.
        let mut f = header("-Y 10000 +X 10000");
        f.extend_from_slice(&[0u8; 100]);
        let e = decode(&f).unwrap_err().to_string();
        assert!(e.starts_with("truncated: header claims 10000x10000 pixels but only 100 bytes follow"), "{e}");
        assert!(t.elapsed().as_millis() < 500);
        let mut f = header("-Y 0 +X 5");
        f.extend_from_slice(&[0u8; 100]);
        assert_eq!(decode(&f).unwrap_err().to_string(), "empty image: header claims 5x0 pixels");
    }

    #[test]
    fn rle_run_past_end_of_row() {
        let mut f = header("-Y 1 +X 8");
        f.extend_from_slice(&[2, 2, 0, 8, 128 + 9, 7]);
        f.extend_from_slice(&[0u8; 40]);
        let e = decode(&f).unwrap_err().to_string();
        assert!(e.contains("scanline 0") && e.contains("past the end"), "{e}");
        // Literal past the end, and a zero count.
        let mut f = header("-Y 1 +X 8");
        f.extend_from_slice(&[2, 2, 0, 8, 4, 1, 2, 3, 4, 5, 1, 2, 3, 4, 5]);
        f.extend_from_slice(&[0u8; 40]);
        assert!(decode(&f).unwrap_err().to_string().contains("past the end"));
        let mut f = header("-Y 1 +X 8");
        f.extend_from_slice(&[2, 2, 0, 8, 0]);
        f.extend_from_slice(&[0u8; 40]);
        assert!(decode(&f).unwrap_err().to_string().contains("count 0"));
        // Encoded width disagrees with the header.
        let mut f = header("-Y 1 +X 8");
        f.extend_from_slice(&[2, 2, 0, 9]);
        f.extend_from_slice(&[0u8; 40]);
        let e = decode(&f).unwrap_err().to_string();
        assert_eq!(e, "scanline 0: RLE scanline length 9 does not match the image width 8");
    }

    #[test]
    fn matches_image_crate_on_real_files() {
        // Each map from assets/maps/ when it ships there, else from ../shared/data/envmaps/.
        for name in [
            "grace-new_256x128.hdr",
            "st_fagans_interior_1k.hdr",
            "rooitou_park_1k.hdr",
            "studio_small_03_1k.hdr",
            "grace_probe.hdr",
        ] {
            let path = crate::test_skip::real_map(name);
            let Ok(bytes) = std::fs::read(&path) else {
                crate::test_skip::skip_missing_data(&format!("{} is missing", path.display()));
                continue;
            };
            let ours = decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
            let theirs = image::load_from_memory_with_format(&bytes, image::ImageFormat::Hdr).unwrap().to_rgb32f();
            assert_eq!((ours.width, ours.height), (theirs.width() as usize, theirs.height() as usize));
            let raw = theirs.into_raw();
            assert_eq!(ours.data.len(), raw.len());
            for (i, (a, b)) in ours.data.iter().zip(&raw).enumerate() {
                assert!(a.to_bits() == b.to_bits(), "{name}: sample {i}: {a} vs {b}");
            }
            if name == "grace-new_256x128.hdr" {
                assert_eq!((ours.width, ours.height), (256, 128));
                // Decoding -> encoding -> decoding is exact (m * 2^(E-136) re-encodes to itself).
                assert_eq!(decode(&encode(&ours)).unwrap(), ours);
            }
        }
    }
}
