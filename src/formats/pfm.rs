//! Portable Float Map (`.pfm`): a hand-written reader and writer (the `image` crate has no PFM
//! support at all, `../shared/NOTES.md`, "Formats").
//!
//! # The format (Netpbm "PFM" page; Paul Debevec's HDRShop, which introduced it)
//!
//! ```text
//! PF            "PF" = 3 channels (RGB), "Pf" = 1 channel (grey)
//! 1024 512      width height (ASCII decimal)
//! -1.0          scale: its SIGN gives the byte order (negative = little-endian, positive =
//!               big-endian); exactly ONE whitespace byte (normally '\n') follows it
//! <W*H*C f32>   raw IEEE-754 floats, no padding, rows stored BOTTOM TO TOP
//! ```
//!
//! Tokens may be separated by any ASCII whitespace (spaces, tabs, newlines), as several writers
//! put width and height on separate lines. `|scale|` is usually 1 and is *not* applied: it is not a
//! brightness multiplier to apply blindly (`../shared/data/envmaps/SOURCES.md`, "Format
//! pitfalls"); values are returned as stored. The reader flips the rows to hdrflow's top-first
//! order; the writer writes little-endian (scale `-1.0`) and bottom-up rows.
//!
//! One leniency: if the byte after the scale is `\r` followed by `\n` and the payload is then
//! exactly one byte too long, the `\r\n` (a Windows line ending) is taken as the separator.
//!
//! # Hostile input
//!
//! Width or height 0, more than [`MAX_PIXELS`] pixels, or fewer than `W*H*C*4` payload bytes are
//! refused *before* the output is allocated. Trailing bytes after the payload are ignored.

use super::{FormatError, MAX_PIXELS};
use crate::values::Image;

fn err(msg: impl Into<String>) -> FormatError {
    FormatError::Invalid(msg.into())
}

/// The next whitespace-separated token from `pos` (skipping leading ASCII whitespace).
fn token<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    while bytes.get(*pos).is_some_and(|b| b.is_ascii_whitespace()) {
        *pos += 1;
    }
    let start = *pos;
    while bytes.get(*pos).is_some_and(|b| !b.is_ascii_whitespace()) {
        *pos += 1;
    }
    if *pos > start {
        bytes.get(start..*pos)
    } else {
        None
    }
}

fn parse_token<T: std::str::FromStr>(tok: Option<&[u8]>, what: &str) -> Result<T, FormatError> {
    let tok = tok.ok_or_else(|| err(format!("truncated PFM header (no {what})")))?;
    std::str::from_utf8(tok)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| err(format!("bad PFM {what} {:?}", String::from_utf8_lossy(&tok[..tok.len().min(40)]))))
}

/// The image size a PFM header declares (`width`, `height`), from the file's first bytes.
pub fn header_size(bytes: &[u8]) -> Result<(usize, usize), FormatError> {
    if !(bytes.starts_with(b"PF") || bytes.starts_with(b"Pf")) {
        return Err(err("not a PFM file (bad magic: expected \"PF\" or \"Pf\")"));
    }
    let mut pos = 2;
    let width: usize = parse_token(token(bytes, &mut pos), "width")?;
    let height: usize = parse_token(token(bytes, &mut pos), "height")?;
    Ok((width, height))
}

/// Decodes a PFM file: 3 channels for `PF`, 1 for `Pf`, row 0 at the top (the file's last row),
/// values exactly as stored (the scale's magnitude is not applied).
pub fn decode(bytes: &[u8]) -> Result<Image, FormatError> {
    let channels = if bytes.starts_with(b"PF") {
        3
    } else if bytes.starts_with(b"Pf") {
        1
    } else {
        return Err(err("not a PFM file (bad magic: expected \"PF\" or \"Pf\")"));
    };
    if !bytes.get(2).is_some_and(|b| b.is_ascii_whitespace()) {
        return Err(err("not a PFM file (bad magic: no whitespace after \"PF\"/\"Pf\")"));
    }
    let mut pos = 2;
    let width: usize = parse_token(token(bytes, &mut pos), "width")?;
    let height: usize = parse_token(token(bytes, &mut pos), "height")?;
    let scale: f64 = parse_token(token(bytes, &mut pos), "scale")?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(err(format!("bad PFM scale {scale} (must be finite and non-zero)")));
    }
    let little_endian = scale < 0.0;
    if width == 0 || height == 0 {
        return Err(err(format!("empty image: header claims {width}x{height} pixels")));
    }
    let pixels = width
        .checked_mul(height)
        .filter(|&p| p <= MAX_PIXELS)
        .ok_or_else(|| err(format!("image too large: {width}x{height} pixels (limit {MAX_PIXELS})")))?;
    // pixels <= 2^28, so pixels * 3 * 4 fits in usize on 64-bit; checked for 32-bit targets.
    let samples = pixels * channels;
    let need = samples.checked_mul(4).ok_or_else(|| err(format!("image too large: {width}x{height} pixels")))?;
    // Exactly one whitespace byte after the scale (or "\r\n", see the module docs).
    match bytes.get(pos) {
        Some(b) if b.is_ascii_whitespace() => pos += 1,
        _ => return Err(err("truncated PFM header (no whitespace byte after the scale)")),
    }
    if bytes.get(pos - 1) == Some(&b'\r') && bytes.get(pos) == Some(&b'\n') && bytes.len() - pos == need + 1 {
        pos += 1;
    }
    let payload = bytes.get(pos..).unwrap_or(&[]);
    if payload.len() < need {
        return Err(err(format!(
            "truncated: header claims {width}x{height}x{channels} floats ({need} bytes) but only {} bytes follow",
            payload.len()
        )));
    }
    let row_len = width * channels;
    let mut data = vec![0f32; samples];
    // File row r (bottom first) is output row height - 1 - r.
    for (src, dst) in payload[..need].chunks_exact(row_len * 4).zip(data.chunks_exact_mut(row_len).rev()) {
        for (d, s) in dst.iter_mut().zip(src.chunks_exact(4)) {
            let b = [s[0], s[1], s[2], s[3]];
            *d = if little_endian { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
        }
    }
    Ok(Image::from_vec(width, height, channels, data))
}

/// Encodes `image` as a little-endian PFM (scale `-1.0`): `Pf` for 1 channel, `PF` otherwise
/// (the first three channels), rows bottom to top. Bit-exact: every f32 (NaN payloads included)
/// is stored as is.
pub fn encode(image: &Image) -> Vec<u8> {
    let (w, h, c) = (image.width, image.height, image.channels);
    let out_c = if c == 1 { 1 } else { 3 };
    let magic = if out_c == 1 { "Pf" } else { "PF" };
    let mut out = format!("{magic}\n{w} {h}\n-1.0\n").into_bytes();
    out.reserve(w * h * out_c * 4);
    for y in (0..h).rev() {
        let row: &[f32] = if c == 0 { &[] } else { image.data.get(y * w * c..(y + 1) * w * c).unwrap_or(&[]) };
        for x in 0..w {
            for k in 0..out_c {
                // Missing channels (a 2-channel image, a short buffer) are written as 0.
                let v = if c >= out_c { row.get(x * c + k).copied().unwrap_or(0.0) } else { 0.0 };
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pseudo_random(n: usize, seed: u32) -> Vec<f32> {
        let mut s = seed.wrapping_mul(2654435761) | 1;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                f32::from_bits(s) // any bit pattern: NaNs, infinities, subnormals, negatives
            })
            .collect()
    }

    fn same_bits(a: &Image, b: &Image) -> bool {
        (a.width, a.height, a.channels) == (b.width, b.height, b.channels)
            && a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits())
            && a.data.len() == b.data.len()
    }

    #[test]
    fn round_trip_is_bit_exact() {
        for &(w, h, c) in &[(5usize, 3usize, 3usize), (4, 7, 1), (1, 1, 3), (1, 1, 1)] {
            let img = Image::from_vec(w, h, c, pseudo_random(w * h * c, (w * 31 + h * 7 + c) as u32));
            let bytes = encode(&img);
            assert!(bytes.starts_with(if c == 1 { b"Pf\n" } else { b"PF\n" }));
            let back = decode(&bytes).unwrap();
            assert!(same_bits(&img, &back), "{w}x{h}x{c}");
        }
    }

    #[test]
    fn rows_are_stored_bottom_up() {
        let img = Image::from_vec(1, 2, 1, vec![1.0, 2.0]); // top = 1, bottom = 2
        let bytes = encode(&img);
        let hdr = b"Pf\n1 2\n-1.0\n".len();
        assert_eq!(&bytes[hdr..hdr + 4], &2.0f32.to_le_bytes());
        assert_eq!(&bytes[hdr + 4..], &1.0f32.to_le_bytes());
    }

    #[test]
    fn big_endian_hand_written_with_odd_whitespace() {
        // 2x1 RGB, big-endian (positive scale, |scale| = 4 must NOT be applied).
        let mut f = b"PF\n 2\t1\n\n4.0\n".to_vec();
        for v in [1.0f32, 2.0, 3.0, -4.0, 0.5, 1e30] {
            f.extend_from_slice(&v.to_be_bytes());
        }
        let img = decode(&f).unwrap();
        assert_eq!((img.width, img.height, img.channels), (2, 1, 3));
        assert_eq!(img.data, vec![1.0, 2.0, 3.0, -4.0, 0.5, 1e30]);
        // 1x2 grey, big-endian, bottom row first.
        let mut f = b"Pf 1 2 1\n".to_vec();
        f.extend_from_slice(&7.0f32.to_be_bytes());
        f.extend_from_slice(&9.0f32.to_be_bytes());
        assert_eq!(decode(&f).unwrap().data, vec![9.0, 7.0]);
    }

    #[test]
    fn crlf_after_scale_tolerated() {
        let mut f = b"Pf\r\n1 1\r\n-1.0\r\n".to_vec();
        f.extend_from_slice(&3.5f32.to_le_bytes());
        assert_eq!(decode(&f).unwrap().data, vec![3.5]);
    }

    #[test]
    fn truncated() {
        let bytes = encode(&Image::from_vec(3, 2, 3, vec![1.0; 18]));
        for n in 0..bytes.len() {
            let e = decode(&bytes[..n]).unwrap_err().to_string();
            // A prefix cuts the magic ("PF\n" -> "P"), the scale ("-1.0" -> "-") or the data.
            let refused = ["truncated", "not a PFM file (bad magic", "bad PFM scale \"-\""];
            assert!(refused.iter().any(|r| e.starts_with(r)), "prefix {n}: {e}");
        }
        let e = decode(&bytes[..bytes.len() - 1]).unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
    }

    #[test]
    fn huge_header() {
        let mut f = b"PF\n100000 100000\n-1.0\n".to_vec();
        f.extend_from_slice(&[0u8; 100]);
        assert_eq!(decode(&f).unwrap_err().to_string(), "image too large: 100000x100000 pixels (limit 268435456)");
        let mut f = b"PF\n10000 10000\n-1.0\n".to_vec();
        f.extend_from_slice(&[0u8; 100]);
        assert!(decode(&f).unwrap_err().to_string().contains("truncated"));
        let e = decode(b"PF\n18446744073709551615 2\n-1.0\n").unwrap_err().to_string();
        assert_eq!(e, "image too large: 18446744073709551615x2 pixels (limit 268435456)");
        assert_eq!(decode(b"PF\n0 2\n-1.0\n").unwrap_err().to_string(), "empty image: header claims 0x2 pixels");
    }

    #[test]
    fn bad_magic_and_bad_tokens() {
        assert!(decode(b"P6\n1 1\n255\n\0\0\0").unwrap_err().to_string().contains("bad magic"));
        let message = |bytes: &[u8]| decode(bytes).unwrap_err().to_string();
        assert_eq!(message(b""), "not a PFM file (bad magic: expected \"PF\" or \"Pf\")");
        assert_eq!(message(b"PFX 1 1 -1\n\0\0\0\0"), "not a PFM file (bad magic: no whitespace after \"PF\"/\"Pf\")");
        assert_eq!(
            message(b"PF\n1 1\nNaN\n\0\0\0\0\0\0\0\0\0\0\0\0"),
            "bad PFM scale NaN (must be finite and non-zero)"
        );
        assert_eq!(message(b"PF\n1 -1\n-1.0\n\0\0\0\0\0\0\0\0\0\0\0\0"), "bad PFM height \"-1\"");
        assert_eq!(message(b"PF\n1 1\n-1.0"), "truncated PFM header (no whitespace byte after the scale)");
    }
}
