//! The RGBE writer: frexp conversion to shared-exponent bytes and new-style RLE rows (see the
//! "Writer" section of the [parent module](super)).

use rayon::prelude::*;

use crate::values::Image;

/// The largest value an RGBE pixel can hold: mantissa byte 255, exponent byte 255 -> 255 * 2^119.
pub(super) fn max_rgbe_value() -> f64 {
    255.0 * 2f64.powi(119)
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
