//! OpenEXR (`.exr`) through the `exr` crate (pure Rust, 1.74: reads every standard compression,
//! DWAA/DWAB included), from and to memory.
//!
//! # Reading
//!
//! 1. **Meta data first.** Only the headers are parsed (`MetaData::read_from_buffered`). Every
//!    part's data window (and the display window) must hold at most [`MAX_PIXELS`] pixels, and the
//!    decoded size the header implies (the sum over channels of samples x bytes per sample, with
//!    subsampling) must stay within the pixel budget of `MAX_PIXELS` RGBA f32 pixels. Then the
//!    chunk offset table is checked: it must fit in the file, and every offset must point inside
//!    the file past the headers. These are the only size checks: there is no assumed maximum
//!    compression ratio (DWAA/DWAB and flat areas under ZIP compress far beyond any fixed
//!    ratio), so a valid file is never refused for being small. Without the checks a 40-byte
//!    header could make the decoder allocate gigabytes.
//! 2. **Which part.** `part: N` (0-based) or `layer: "name"` (a part's `name` attribute, or a
//!    channel prefix such as `diffuse` for `diffuse.R`) choose; otherwise the first part with a
//!    colour channel (`R`, `G`, `B` or `Y`, bare or layer-prefixed) is taken, so a depth-only part
//!    before the RGB part is skipped. Its largest resolution level is read.
//! 3. **Channels.** `R`, `G`, `B` (and `A`, kept as a fourth channel) are picked by name whatever
//!    their stored order and sample type (f16, f32, u32: all become f32; f16 exactly as OpenEXR
//!    converts it, signalling NaNs keeping their bits). Luminance/chroma files
//!    (`Y`, `RY`, `BY`) become RGB. **2x2-subsampled chroma**, the layout OpenEXR's
//!    `RgbaOutputFile` writes, goes through OpenEXR's own reconstruction ([`super::yca`]: its
//!    filters, clamping, half rounding and saturation fix, bit for bit; the subsampled channels
//!    are decoded by our patch of the `exr` crate, `vendor/exr/PATCHES.md`). Full-resolution
//!    chroma (which `RgbaInputFile` refuses) uses OpenEXR's per-pixel formula
//!    (ImfRgbaYca `YCAtoRGBA`): `R = (RY + 1) Y`, `B = (BY + 1) Y`,
//!    `G = (Y - R yw.x - B yw.z) / yw.y`, `yw` being the luminance weights of the file's
//!    chromaticities (Rec. 709 when absent); `RY = BY = 0` gives grey `Y`. Any other subsampled
//!    channel is upsampled bilinearly (OpenEXR's `InputFile` refuses to read one into a
//!    full-resolution buffer). `Y` alone gives
//!    one channel (grey, which is correct). If only some of R/G/B exist, the missing ones are 0.
//!    No colour channel: an error listing the channels.
//! 4. **Window.** `Display` (default): the image is the display window; pixels outside the data
//!    window are 0 (alpha too), data outside the display window is cropped. `Data`: the data
//!    window as stored.
//! 5. **Colour space.** `Linear709` (default): RGB is converted from the file's `chromaticities`
//!    (RGB -> XYZ -> Rec. 709 RGB) to linear Rec. 709; no attribute means Rec. 709 already.
//!    No chromatic adaptation, as OpenEXR (see `Primaries::to_rec709`: the OpenEXR test set's
//!    `XYZ.exr`, white E, matches `Rec709.exr` only this way). `AsStored`: values untouched.
//! 6. **Orientation.** EXR rows run top to bottom (y grows downwards), like ours; nothing is
//!    flipped. (`grace_latlong.exr` is itself stored upside-down, row 0 = straight down:
//!    `../shared/data/envmaps/SOURCES.md`. Flipping it is the caller's decision.)
//! 7. **Refused.** Deep data: a deep part is refused when chosen, naming it; in a multi-part
//!    file the flat parts beside deep ones are read (only the chosen part's chunks are read:
//!    `read_part`; our patch of the `exr` crate lets such files pass its validation). A single-part file whose `type` attribute says `deepscanline`
//!    or `deeptile` while the version field's deep bit is clear is flat (OpenEXR reads it): the
//!    attribute is dropped from an in-memory copy and the file read as flat.
//!
//! Errors from the `exr` crate become [`FormatError::Invalid`]s carrying their text. As a
//! belt-and-braces guard against panics on hostile input inside the dependency, the whole decode
//! runs under `std::panic::catch_unwind`, and a panic becomes [`FormatError::DecoderPanicked`]
//! (shown as "exr decoder panicked: ..."): an error for the user, a failure for the fuzz target
//! and the corpus replays (`fuzz/checks.rs`).
//!
//! # Writing
//!
//! [`encode`]: one layer of f32 `R`, `G`, `B` (or `Y` for 1 channel), ZIP compression (16-line
//! blocks, OpenEXR's `ZIP_COMPRESSION`), scanlines, increasing Y. f32 rather than half because real
//! suns exceed the half-float maximum 65504 (`../shared/NOTES.md`).

use std::panic::{catch_unwind, AssertUnwindSafe};

use super::{ColorSpace, DecodeOptions, FormatError, Window, MAX_PIXELS};
use crate::values::Image;

mod channels;
mod checks;
mod encode;
mod parts;

use channels::{full_plane, interleave, place, read_part, DecodedChannel};
use checks::{check_sizes, drop_wrong_deep_type, read_meta};
pub use encode::{encode, encode_with, EncodeOptions, ExrCompression};
use parts::{choose_part, chromaticities_of};

/// Images smaller than this many pixels are read and written on the calling thread: the `exr`
/// crate builds a thread pool per parallel call, which costs more than it saves on small images.
const PARALLEL_MIN_PIXELS: usize = 1 << 16;

/// The decoded bytes a header may imply: `MAX_PIXELS` pixels of 4 f32 channels.
const MAX_DECODED_BYTES: u128 = MAX_PIXELS as u128 * 16;

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Decodes an OpenEXR file from memory with the default options (see the module docs).
pub fn decode(bytes: &[u8]) -> Result<Image, FormatError> {
    decode_with(bytes, &DecodeOptions::default())
}

/// Decodes an OpenEXR file from memory (see the module docs).
pub fn decode_with(bytes: &[u8], options: &DecodeOptions) -> Result<Image, FormatError> {
    caught(|| decode_inner(bytes, options), FormatError::DecoderPanicked)
}

/// `f()`, with a panic inside it turned into the error `panicked(message)`.
fn caught<T>(
    f: impl FnOnce() -> Result<T, FormatError>,
    panicked: fn(String) -> FormatError,
) -> Result<T, FormatError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => Err(panicked(panic_message(&*payload))),
    }
}

fn decode_inner(bytes: &[u8], options: &DecodeOptions) -> Result<Image, FormatError> {
    let meta = read_meta(bytes)?;
    if meta.headers.is_empty() {
        return Err(FormatError::Invalid("EXR file has no layers".into()));
    }
    if let Some(fixed) = drop_wrong_deep_type(bytes, &meta) {
        return decode_inner(&fixed, options);
    }
    let largest = check_sizes(bytes, &meta, options.window)?;
    let (part, prefix) = choose_part(&meta, options)?;

    let (w, h, mut list) = read_part(bytes, part, largest >= PARALLEL_MIN_PIXELS)?;
    let header = &meta.headers[part];

    let pixels = w
        .checked_mul(h)
        .filter(|&p| p > 0 && p <= MAX_PIXELS)
        .ok_or_else(|| FormatError::Invalid(format!("bad EXR layer size {w}x{h}")))?;
    let names: Vec<String> = list.iter().map(|c| c.name.clone()).collect();
    let find = |want: &str| -> Option<usize> {
        if prefix.is_empty() {
            names.iter().position(|n| n == want).or_else(|| {
                let suffix = format!(".{want}");
                names.iter().position(|n| n.ends_with(&suffix))
            })
        } else {
            let full = format!("{prefix}.{want}");
            names.iter().position(|n| *n == full)
        }
    };
    let samplings: Vec<(usize, usize)> = list.iter().map(|c| c.sampling).collect();
    // Each channel's samples are moved out of `list` once, not copied.
    let plane = |list: &mut Vec<DecodedChannel>, index: Option<usize>| -> Result<Option<Vec<f32>>, FormatError> {
        index.map(|i| full_plane(std::mem::take(&mut list[i]), w, h)).transpose()
    };
    let primaries = chromaticities_of(header.shared_attributes.chromaticities.as_ref());

    let (ri, gi, bi, yi) = (find("R"), find("G"), find("B"), find("Y"));
    let (mut data, c) = if ri.is_some() || gi.is_some() || bi.is_some() {
        let (r, g, b) = (plane(&mut list, ri)?, plane(&mut list, gi)?, plane(&mut list, bi)?);
        let zero = vec![0.0; pixels];
        let (r, g, b) = (r.unwrap_or_else(|| zero.clone()), g.unwrap_or_else(|| zero.clone()), b.unwrap_or(zero));
        interleave(&[Some(r), Some(g), Some(b), plane(&mut list, find("A"))?])
    } else if let Some(yi) = yi {
        let (ryi, byi) = (find("RY"), find("BY"));
        let subsampled_chroma = ryi.zip(byi).filter(|&(r, b)| samplings[r] == (2, 2) && samplings[b] == (2, 2));
        if let Some((ryi, byi)) = subsampled_chroma {
            // What `RgbaOutputFile` writes: OpenEXR's own reconstruction, bit for bit, on the
            // channels rounded to half as its `Rgba` frame buffer holds them.
            let mut half_plane =
                |i: usize| -> Vec<f32> { super::yca::round_to_half(std::mem::take(&mut list[i].values)) };
            let (y, ry, by) = (half_plane(yi), half_plane(ryi), half_plane(byi));
            let chroma = (w / 2) * (h / 2);
            if w % 2 != 0 || h % 2 != 0 || y.len() != pixels || ry.len() != chroma || by.len() != chroma {
                return Err(FormatError::Invalid(format!(
                    "EXR luminance/chroma part {part}: {}, {} and {} samples for {w}x{h} pixels",
                    y.len(),
                    ry.len(),
                    by.len()
                )));
            }
            let rgb = super::yca::YcaPlanes { width: w, height: h, y: &y, ry: &ry, by: &by }.to_rgb(&primaries);
            match plane(&mut list, find("A"))? {
                None => (rgb, 3),
                // Alpha: the one case where the interleaved RGB is split and woven again.
                Some(a) => {
                    let channel = |k: usize| Some(rgb.iter().skip(k).step_by(3).copied().collect::<Vec<f32>>());
                    interleave(&[channel(0), channel(1), channel(2), Some(a)])
                }
            }
        } else {
            let y = full_plane(std::mem::take(&mut list[yi]), w, h)?;
            let (ry, by) = (plane(&mut list, ryi)?, plane(&mut list, byi)?);
            if ry.is_none() && by.is_none() {
                interleave(&[Some(y), None, None, plane(&mut list, find("A"))?])
            } else {
                // Full-resolution chroma (which `RgbaInputFile` refuses): `YCAtoRGBA` per pixel.
                let yw = primaries.luminance_weights();
                let zero = vec![0.0; pixels];
                let (ry, by) = (ry.unwrap_or_else(|| zero.clone()), by.unwrap_or(zero));
                let (mut r, mut g, mut b) =
                    (Vec::with_capacity(pixels), Vec::with_capacity(pixels), Vec::with_capacity(pixels));
                for i in 0..pixels {
                    let (yv, ryv, byv) = (y[i] as f64, ry[i] as f64, by[i] as f64);
                    if ryv == 0.0 && byv == 0.0 {
                        r.push(yv as f32);
                        g.push(yv as f32);
                        b.push(yv as f32);
                    } else {
                        let rv = (ryv + 1.0) * yv;
                        let bv = (byv + 1.0) * yv;
                        let gv = (yv - rv * yw[0] - bv * yw[2]) / yw[1];
                        r.push(rv as f32);
                        g.push(gv as f32);
                        b.push(bv as f32);
                    }
                }
                interleave(&[Some(r), Some(g), Some(b), plane(&mut list, find("A"))?])
            }
        }
    } else {
        return Err(FormatError::Invalid(format!(
            "EXR part {part} has no R, G, B or Y channel{} (channels: {})",
            if prefix.is_empty() { String::new() } else { format!(" in layer {prefix:?}") },
            if names.is_empty() { "none".to_string() } else { names.join(", ") }
        )));
    };

    if c >= 3 && options.colorspace == ColorSpace::Linear709 {
        if let Some(m) = primaries.to_rec709() {
            for p in data.chunks_exact_mut(c) {
                let (r, g, b) = (p[0] as f64, p[1] as f64, p[2] as f64);
                for k in 0..3 {
                    p[k] = (m[k][0] * r + m[k][1] * g + m[k][2] * b) as f32;
                }
            }
        }
    }

    let mut out = Image::from_vec(w, h, c, data);
    if options.window == Window::Display {
        let display = header.shared_attributes.display_window;
        let origin = header.own_attributes.layer_position;
        out = place(out, (origin.0 as i64, origin.1 as i64), display);
    }
    Ok(out)
}

/// The size `decode_with` would return, from the headers only (`None` when unreadable).
pub fn header_size(bytes: &[u8], options: &DecodeOptions) -> Option<(usize, usize)> {
    let meta = read_meta(bytes).ok()?;
    let (part, _) = choose_part(&meta, options).ok()?;
    let header = &meta.headers[part];
    Some(match options.window {
        Window::Display => {
            let d = header.shared_attributes.display_window.size;
            (d.0, d.1)
        }
        Window::Data => (header.layer_size.0, header.layer_size.1),
    })
}

#[cfg(test)]
mod tests;
