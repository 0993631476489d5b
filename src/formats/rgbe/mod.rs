//! Radiance RGBE (`.hdr`, `.pic`): a hand-written reader and writer.
//!
//! Files: `header` (header and resolution line), `decode` (the three scanline encodings into
//! f32), `encode` (the writer), `tests`. The writer emits what the reader's fast path expects, so
//! the round-trip tests sit beside both in `tests.rs`.
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

mod decode;
mod encode;
mod header;
#[cfg(test)]
mod tests;

pub use decode::decode;
pub use encode::encode;
pub use header::{header_size, primaries};

use super::FormatError;

fn err(msg: impl Into<String>) -> FormatError {
    FormatError::Invalid(msg.into())
}
