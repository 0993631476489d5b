//! The RGBE decoder: flat, old-RLE and new-style RLE scanlines straight from the byte slice into
//! f32 through a 256-entry exponent table, then the layout's flips and transpose (see the
//! [parent module](super)).

use super::err;
use super::header::{parse_header, Layout};
use crate::formats::{FormatError, MAX_PIXELS};
use crate::values::Image;

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
