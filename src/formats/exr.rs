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

use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};

use ::exr::meta::attribute::{Chromaticities, IntegerBounds, SampleType};
use ::exr::prelude::traits::*;
use ::exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, LayerAttributes, MetaData, SmallVec};

use super::{ColorSpace, DecodeOptions, FormatError, Primaries, Window, MAX_PIXELS};
use crate::values::Image;

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

fn read_meta(bytes: &[u8]) -> Result<MetaData, FormatError> {
    MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| FormatError::Invalid(format!("not a readable EXR file: {e}")))
}

/// The byte position just past the header(s), where the chunk offset tables start.
fn headers_end(bytes: &[u8], multipart: bool) -> Option<usize> {
    let mut at = 8usize;
    loop {
        // One header: attributes until an empty name.
        let mut attributes = 0;
        loop {
            if *bytes.get(at)? == 0 {
                at += 1;
                break;
            }
            let name_end = at + bytes.get(at..)?.iter().position(|&b| b == 0)?;
            let type_end = name_end + 1 + bytes.get(name_end + 1..)?.iter().position(|&b| b == 0)?;
            let size = i32::from_le_bytes(bytes.get(type_end + 1..type_end + 5)?.try_into().ok()?);
            at = type_end + 5 + usize::try_from(size).ok()?;
            attributes += 1;
        }
        if !multipart || attributes == 0 {
            return Some(at);
        }
        // Multi-part: another header follows unless the next byte ends the list.
        if *bytes.get(at)? == 0 {
            return Some(at + 1);
        }
    }
}

/// The single-part "flat image whose `type` says deep" repair: drops the `type` attribute from
/// a copy and shifts the offset table. `None` when the file is not of that kind.
fn drop_wrong_deep_type(bytes: &[u8], meta: &MetaData) -> Option<Vec<u8>> {
    if meta.requirements.has_deep_data || meta.requirements.has_multiple_layers || meta.headers.len() != 1 {
        return None;
    }
    if !meta.headers[0].deep {
        return None;
    }
    let key = b"type\0string\0";
    let at = bytes.windows(key.len()).position(|w| w == key)?;
    let end = headers_end(bytes, false)?;
    if at >= end {
        return None;
    }
    let size = i32::from_le_bytes(bytes.get(at + key.len()..at + key.len() + 4)?.try_into().ok()?);
    let value = bytes.get(at + key.len() + 4..at + key.len() + 4 + usize::try_from(size).ok()?)?;
    if value != b"deepscanline" && value != b"deeptile" {
        return None;
    }
    let cut = key.len() + 4 + value.len();
    let mut out = Vec::with_capacity(bytes.len());
    out.extend_from_slice(&bytes[..at]);
    out.extend_from_slice(&bytes[at + cut..]);
    let patched = read_meta(&out).ok()?;
    let table = end - cut;
    for i in 0..patched.headers.first()?.chunk_count {
        let slot = out.get_mut(table + 8 * i..table + 8 * i + 8)?;
        let offset = u64::from_le_bytes((&*slot).try_into().ok()?);
        slot.copy_from_slice(&offset.checked_sub(cut as u64)?.to_le_bytes());
    }
    Some(out)
}

fn sample_bytes(t: SampleType) -> u128 {
    match t {
        SampleType::F16 => 2,
        SampleType::F32 | SampleType::U32 => 4,
    }
}

/// The size checks of the module docs (before any pixel is decoded).
fn check_sizes(bytes: &[u8], meta: &MetaData, window: Window) -> Result<usize, FormatError> {
    let mut largest = 0usize;
    let mut chunks = 0u128;
    for header in meta.headers.iter() {
        let (w, h) = (header.layer_size.0, header.layer_size.1);
        let pixels = w
            .checked_mul(h)
            .filter(|&p| p <= MAX_PIXELS)
            .ok_or_else(|| FormatError::Invalid(format!("image too large: {w}x{h} pixels (limit {MAX_PIXELS})")))?;
        let display = header.shared_attributes.display_window.size;
        if window == Window::Display && display.0.checked_mul(display.1).is_none_or(|p| p > MAX_PIXELS) {
            return Err(FormatError::Invalid(format!(
                "display window too large: {}x{} pixels (limit {MAX_PIXELS})",
                display.0, display.1
            )));
        }
        let decoded: u128 = header
            .channels
            .list
            .iter()
            .map(|c| {
                let (sx, sy) = (c.sampling.0.max(1) as u128, c.sampling.1.max(1) as u128);
                (w as u128).div_ceil(sx) * (h as u128).div_ceil(sy) * sample_bytes(c.sample_type)
            })
            .sum();
        if decoded > MAX_DECODED_BYTES {
            return Err(FormatError::Invalid(format!(
                "image too large: {w}x{h} pixels x {} channels decode to {decoded} bytes (limit {MAX_DECODED_BYTES})",
                header.channels.list.len()
            )));
        }
        chunks += header.chunk_count as u128;
        largest = largest.max(pixels);
    }
    // The chunk offset tables: present in full, every offset inside the file past them.
    let end = headers_end(bytes, meta.requirements.has_multiple_layers)
        .ok_or_else(|| FormatError::Invalid("truncated: EXR header runs past the end of the file".into()))?;
    let table_end = end as u128 + 8 * chunks;
    if table_end > bytes.len() as u128 {
        return Err(FormatError::Invalid(format!(
            "truncated: the header promises {chunks} chunks, whose offset table alone needs {table_end} bytes, \
             but the file has {}",
            bytes.len()
        )));
    }
    for i in 0..chunks as usize {
        let slot = &bytes[end + 8 * i..end + 8 * i + 8];
        let offset = u64::from_le_bytes(slot.try_into().expect("8 bytes"));
        if offset < table_end as u64 || offset >= bytes.len() as u64 {
            return Err(FormatError::Invalid(format!(
                "truncated or damaged: chunk {i} starts at byte {offset}, outside the file's {} bytes of pixel data",
                bytes.len()
            )));
        }
    }
    Ok(largest)
}

fn has_colour(names: &[String], prefix: &str) -> bool {
    ["R", "G", "B", "Y"].iter().any(|c| {
        names.iter().any(|n| {
            if prefix.is_empty() {
                n == c || n.ends_with(&format!(".{c}"))
            } else {
                *n == format!("{prefix}.{c}")
            }
        })
    })
}

fn part_name(header: &::exr::meta::header::Header) -> String {
    header.own_attributes.layer_name.as_ref().map(|t| t.to_string()).unwrap_or_default()
}

/// Chooses the part (and the channel prefix within it) from the options.
fn choose_part(meta: &MetaData, options: &DecodeOptions) -> Result<(usize, String), FormatError> {
    let names =
        |i: usize| -> Vec<String> { meta.headers[i].channels.list.iter().map(|c| c.name.to_string()).collect() };
    let describe = || -> String {
        meta.headers
            .iter()
            .enumerate()
            .map(|(i, h)| {
                format!("part {i} {:?}{}: {}", part_name(h), if h.deep { " (deep)" } else { "" }, names(i).join(", "))
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    let layer = options.layer.as_deref().filter(|l| !l.is_empty());
    let chosen = if let Some(p) = options.part {
        if p >= meta.headers.len() {
            return Err(FormatError::Invalid(format!("EXR file has no part {p} ({})", describe())));
        }
        match layer {
            Some(l) if part_name(&meta.headers[p]) != l => (p, l.to_string()),
            _ => (p, String::new()),
        }
    } else if let Some(l) = layer {
        if let Some(p) = meta.headers.iter().position(|h| part_name(h) == l) {
            (p, String::new())
        } else if let Some(p) = (0..meta.headers.len()).find(|&p| !meta.headers[p].deep && has_colour(&names(p), l)) {
            (p, l.to_string())
        } else {
            return Err(FormatError::Invalid(format!("EXR file has no part or layer {l:?} ({})", describe())));
        }
    } else {
        match (0..meta.headers.len()).find(|&p| !meta.headers[p].deep && has_colour(&names(p), "")) {
            Some(p) => (p, String::new()),
            None => {
                return Err(FormatError::Invalid(format!(
                    "EXR file has no part with a colour channel (R, G, B or Y) that is not deep data ({})",
                    describe()
                )))
            }
        }
    };
    if meta.headers[chosen.0].deep {
        return Err(FormatError::Invalid(format!("EXR part {} is deep data, which is not supported", chosen.0)));
    }
    Ok(chosen)
}

/// One channel of the chosen part as decoded: f32 samples in the channel's own sample grid
/// (`width / sampling.0` x `height / sampling.1`).
#[derive(Default)]
struct DecodedChannel {
    name: String,
    sampling: (usize, usize),
    values: Vec<f32>,
}

/// Decodes the largest resolution level of part `part` only, through the `exr` crate's block
/// API: the other parts' chunks (deep ones included) are never read. The part is cut into
/// horizontal bands (a scan line block's rows, or a row of tiles), and the bands are decoded in
/// parallel on our rayon pool straight into each channel's plane (the crate's image reader
/// builds a thread pool per call, decodes every part, and copies each line once more).
fn read_part(bytes: &[u8], part: usize, parallel: bool) -> Result<(usize, usize, Vec<DecodedChannel>), FormatError> {
    use ::exr::block::chunk::Chunk;
    use ::exr::block::UncompressedBlock;
    use ::exr::meta::BlockDescription;
    use rayon::prelude::*;

    let failed = |e: ::exr::error::Error| FormatError::Invalid(format!("EXR decoding failed: {e}"));
    let reader = ::exr::block::read(Cursor::new(bytes), false).map_err(failed)?;
    let meta = reader.meta_data().clone();
    let header = &meta.headers[part];
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    let chunks = reader
        .filter_chunks(false, |_, tile, block| block.layer == part && tile.is_largest_resolution_level())
        .map_err(failed)?;

    // Rows per band: the scan line block height, or the tile height.
    let band_rows = match header.blocks {
        BlockDescription::ScanLines => header.compression.scan_lines_per_block(),
        BlockDescription::Tiles(tiles) => tiles.tile_size.1,
    }
    .max(1);
    let band_count = h.div_ceil(band_rows);
    let mut bands: Vec<Vec<Chunk>> = (0..band_count).map(|_| Vec::new()).collect();
    for chunk in chunks {
        let chunk = chunk.map_err(failed)?;
        let tile = header.get_block_data_indices(&chunk.compressed_block).map_err(failed)?;
        let bounds = header.get_absolute_block_pixel_coordinates(tile).map_err(failed)?;
        let band = usize::try_from(bounds.position.1).unwrap_or(usize::MAX) / band_rows;
        bands
            .get_mut(band)
            .ok_or_else(|| FormatError::Invalid(format!("EXR block outside part {part}'s data window")))?
            .push(chunk);
    }

    let mut channels: Vec<DecodedChannel> = header
        .channels
        .list
        .iter()
        .map(|c| {
            let sampling = (c.sampling.0.max(1), c.sampling.1.max(1));
            DecodedChannel {
                name: c.name.to_string(),
                sampling,
                values: vec![0.0; (w / sampling.0) * (h / sampling.1)],
            }
        })
        .collect();
    // Each band's slice of every plane: the channel rows `ceil(y0 / sy) .. ceil(y1 / sy)`, with
    // the first row's index and the channel's row width.
    type BandSlice<'p> = (usize, usize, &'p mut [f32]);
    let mut targets: Vec<Vec<BandSlice>> = (0..band_count).map(|_| Vec::new()).collect();
    for channel in channels.iter_mut() {
        let (sx, sy) = channel.sampling;
        let cw = w / sx;
        let mut rest: &mut [f32] = &mut channel.values;
        for (band, target) in targets.iter_mut().enumerate() {
            let first = (band * band_rows).div_ceil(sy);
            let end = ((band + 1) * band_rows).min(h).div_ceil(sy);
            let (mine, others) = std::mem::take(&mut rest).split_at_mut((end - first) * cw);
            target.push((first, cw, mine));
            rest = others;
        }
    }

    let decode_band = |(chunks, mut target): (Vec<Chunk>, Vec<BandSlice>)| -> Result<(), FormatError> {
        let mut bits: Vec<u16> = Vec::new();
        for chunk in chunks {
            let block = UncompressedBlock::decompress_chunk(chunk, &meta, false).map_err(failed)?;
            for line in block.lines(&header.channels) {
                let index = line.location;
                let (first, cw, plane) = &mut target[index.channel];
                let start = (index.position.1 - *first) * *cw + index.position.0;
                let out = plane
                    .get_mut(start..start + index.sample_count)
                    .ok_or_else(|| FormatError::Invalid(format!("EXR block outside part {part}'s data window")))?;
                let bytes = line.value;
                match header.channels.list[index.channel].sample_type {
                    SampleType::F16 => {
                        // `half`'s slice conversion (F16C when the CPU has it, chosen once per
                        // line rather than per sample).
                        use half::slice::{HalfBitsSliceExt, HalfFloatSliceExt};
                        bits.clear();
                        bits.extend(bytes.chunks_exact(2).map(|b| u16::from_ne_bytes([b[0], b[1]])));
                        bits.reinterpret_cast::<half::f16>().convert_to_f32_slice(out);
                        keep_signalling_nans(&bits, out);
                    }
                    SampleType::F32 => {
                        for (o, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                            *o = f32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
                        }
                    }
                    SampleType::U32 => {
                        for (o, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                            *o = u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f32;
                        }
                    }
                }
            }
        }
        Ok(())
    };
    let work = bands.into_iter().zip(targets);
    if parallel {
        work.collect::<Vec<_>>().into_par_iter().try_for_each(decode_band)?;
    } else {
        work.into_iter().try_for_each(decode_band)?;
    }
    Ok((w, h, channels))
}

/// Whether half bits are a signalling NaN: exponent all ones, quiet bit (0x0200) clear, and a
/// non-zero payload.
fn is_signalling_nan_half(b: u16) -> bool {
    b & 0x7e00 == 0x7c00 && b & 0x01ff != 0
}

/// OpenEXR converts half to float by shifting the bits (`imath_half_to_float`), so a signalling
/// NaN stays signalling with its payload; the `half` crate, and F16C, set the quiet bit. The value
/// is NaN either way, but not the same bits as OpenEXR (the OpenEXR test image `AllHalfValues.exr`
/// holds all 1022 of them): redo those samples as OpenEXR does. Lines without one (nearly all)
/// cost one vectorised scan.
fn keep_signalling_nans(bits: &[u16], out: &mut [f32]) {
    if !bits.iter().any(|&b| is_signalling_nan_half(b)) {
        return;
    }
    for (o, &b) in out.iter_mut().zip(bits) {
        if is_signalling_nan_half(b) {
            let b = b as u32;
            *o = f32::from_bits((b & 0x8000) << 16 | 0x7f80_0000 | (b & 0x03ff) << 13);
        }
    }
}

/// One channel's samples as f32 at full resolution (bilinear upsampling of a subsampled one).
fn full_plane(channel: DecodedChannel, w: usize, h: usize) -> Result<Vec<f32>, FormatError> {
    let values = channel.values;
    let (sx, sy) = (channel.sampling.0.max(1), channel.sampling.1.max(1));
    let (cw, ch) = (w / sx, h / sy);
    if values.len() != cw * ch || (sx > 1 || sy > 1) && (cw == 0 || ch == 0) {
        return Err(FormatError::Invalid(format!(
            "EXR channel {} has {} samples for {w}x{h} pixels at sampling {sx}x{sy}",
            channel.name,
            values.len()
        )));
    }
    if sx == 1 && sy == 1 {
        return Ok(values);
    }
    // Sample j sits at pixel j * s; between samples, linear interpolation; past the last, clamp.
    let coord = |x: usize, s: usize, n: usize| -> (usize, usize, f32) {
        let j = (x / s).min(n - 1);
        let t = if x / s >= n - 1 { 0.0 } else { (x % s) as f32 / s as f32 };
        (j, (j + 1).min(n - 1), t)
    };
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let (y0, y1, ty) = coord(y, sy, ch);
        for x in 0..w {
            let (x0, x1, tx) = coord(x, sx, cw);
            let a = values[y0 * cw + x0] * (1.0 - tx) + values[y0 * cw + x1] * tx;
            let b = values[y1 * cw + x0] * (1.0 - tx) + values[y1 * cw + x1] * tx;
            out.push(a * (1.0 - ty) + b * ty);
        }
    }
    Ok(out)
}

fn chromaticities_of(c: Option<&Chromaticities>) -> Primaries {
    match c {
        Some(c) => Primaries {
            red: [c.red.0 as f64, c.red.1 as f64],
            green: [c.green.0 as f64, c.green.1 as f64],
            blue: [c.blue.0 as f64, c.blue.1 as f64],
            white: [c.white.0 as f64, c.white.1 as f64],
        },
        None => Primaries::REC709,
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

/// Interleaves planes (absent ones skipped): `[R, G, B, A]` or `[Y]`.
fn interleave(planes: &[Option<Vec<f32>>]) -> (Vec<f32>, usize) {
    let present: Vec<&Vec<f32>> = planes.iter().flatten().collect();
    let c = present.len();
    let n = present.first().map_or(0, |p| p.len());
    let mut data = vec![0.0f32; n * c];
    if c == 0 {
        return (data, c);
    }
    // In parallel over chunks of pixels: this copy is memory-bound and the largest after decoding.
    use rayon::prelude::*;
    const PIXELS_PER_TASK: usize = 1 << 14;
    data.par_chunks_mut(PIXELS_PER_TASK * c).enumerate().for_each(|(task, chunk)| {
        let first = task * PIXELS_PER_TASK;
        for (k, p) in present.iter().enumerate() {
            for (out, &v) in chunk[k..].iter_mut().step_by(c).zip(&p[first..]) {
                *out = v;
            }
        }
    });
    (data, c)
}

/// The display window's pixels: the data-window image placed at `origin`, 0 elsewhere.
fn place(image: Image, origin: (i64, i64), display: IntegerBounds) -> Image {
    let (dw, dh) = (display.size.0, display.size.1);
    let (dx, dy) = (display.position.0 as i64, display.position.1 as i64);
    if (dx, dy) == origin && (dw, dh) == (image.width, image.height) {
        return image;
    }
    let c = image.channels;
    let mut out = Image::from_vec(dw, dh, c, vec![0.0; dw * dh * c]);
    out.names = image.names.clone();
    for y in 0..dh {
        let sy = dy + y as i64 - origin.1;
        if sy < 0 || sy >= image.height as i64 {
            continue;
        }
        for x in 0..dw {
            let sx = dx + x as i64 - origin.0;
            if sx < 0 || sx >= image.width as i64 {
                continue;
            }
            let src = (sy as usize * image.width + sx as usize) * c;
            let dst = (y * dw + x) * c;
            out.data[dst..dst + c].copy_from_slice(&image.data[src..src + c]);
        }
    }
    out
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

crate::choice! {
    /// The compression of a written EXR file (what the `exr` crate writes).
    pub enum ExrCompression {
        /// deflate, 16-line blocks (OpenEXR's ZIP_COMPRESSION), lossless
        Zip,
        /// wavelet + Huffman, 32-line blocks, lossless
        Piz,
        /// DWAA (DCT, 32-line blocks, default level 45): lossy (about 2e-3 at values near 0.5, f32 or half)
        Dwaa,
        /// uncompressed
        None,
    }
}

/// How [`encode_with`] writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncodeOptions {
    pub compression: ExrCompression,
    /// Half floats instead of f32 (values beyond 65504 become infinite, as OpenEXR's conversion).
    pub half: bool,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions { compression: ExrCompression::Zip, half: false }
    }
}

/// Encodes `image` as a ZIP-compressed float32 OpenEXR file, one EXR channel per image channel
/// under the image's channel names (`R G B`, `R G B A`, `Y`, `Z`, ...).
pub fn encode(image: &Image) -> Result<Vec<u8>, FormatError> {
    encode_with(image, &EncodeOptions::default())
}

/// Encodes `image` as an OpenEXR file with the given compression and sample type, one EXR
/// channel per image channel under the image's channel names (alpha `A` kept).
pub fn encode_with(image: &Image, options: &EncodeOptions) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    if w == 0 || h == 0 {
        return Err(FormatError::Invalid(format!("cannot write an empty {w}x{h} image as EXR")));
    }
    if c == 0 || image.names.len() != c {
        return Err(FormatError::Invalid(format!(
            "cannot write an image with {c} channels and {} names as EXR",
            image.names.len()
        )));
    }
    let mut sorted = image.names.clone();
    sorted.sort();
    sorted.dedup();
    if sorted.len() != c || sorted.iter().any(|n| n.is_empty()) {
        return Err(FormatError::Invalid(format!("EXR channel names must be unique and non-empty: {:?}", image.names)));
    }
    let pixels = w * h;
    if image.data.len() != pixels * c {
        return Err(FormatError::Invalid(format!(
            "image buffer has {} samples, expected {w}x{h}x{c}",
            image.data.len()
        )));
    }
    caught(|| encode_inner(image, options), FormatError::EncoderPanicked)
}

fn encode_inner(image: &Image, options: &EncodeOptions) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    let samples = |v: Vec<f32>| -> FlatSamples {
        if options.half {
            FlatSamples::F16(v.into_iter().map(::exr::prelude::f16::from_f32).collect())
        } else {
            FlatSamples::F32(v)
        }
    };
    let list: Vec<AnyChannel<FlatSamples>> = if c == 1 {
        vec![AnyChannel::new(image.names[0].as_str(), samples(image.data.clone()))]
    } else {
        let plane = |k: usize| -> Vec<f32> { image.data.chunks_exact(c).map(|p| p[k]).collect() };
        (0..c).map(|k| AnyChannel::new(image.names[k].as_str(), samples(plane(k)))).collect()
    };
    let channels = AnyChannels::sort(SmallVec::from_vec(list));
    // Scanline blocks, increasing Y.
    let compression = match options.compression {
        ExrCompression::Zip => ::exr::prelude::Compression::ZIP16,
        ExrCompression::Piz => ::exr::prelude::Compression::PIZ,
        ExrCompression::Dwaa => ::exr::prelude::Compression::DWAA(None),
        ExrCompression::None => ::exr::prelude::Compression::Uncompressed,
    };
    let encoding = Encoding { compression, ..Encoding::SMALL_LOSSLESS };
    let layer = ::exr::prelude::Layer::new((w, h), LayerAttributes::default(), encoding, channels);
    let exr_image = ::exr::prelude::Image::from_layer(layer);
    let mut out: Vec<u8> = Vec::new();
    let writer = exr_image.write();
    let writer = if w * h < PARALLEL_MIN_PIXELS { writer.non_parallel() } else { writer };
    writer.to_buffered(Cursor::new(&mut out)).map_err(|e| FormatError::Invalid(format!("EXR encoding failed: {e}")))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_image(w: usize, h: usize, c: usize) -> Image {
        let data = (0..w * h * c)
            .map(|i| ((i * 7919) % 1000) as f32 * 0.37 - 10.0 + if i % 13 == 0 { 69120.0 } else { 0.0 })
            .collect();
        Image::from_vec(w, h, c, data)
    }

    #[test]
    fn round_trip_rgb_and_y() {
        for &(w, h, c) in &[(7usize, 5usize, 3usize), (16, 3, 1), (1, 1, 3), (300, 2, 3)] {
            let img = test_image(w, h, c);
            let bytes = encode(&img).unwrap();
            let back = decode(&bytes).unwrap_or_else(|e| panic!("{w}x{h}x{c}: {e}"));
            // f32 end to end (69120 > half max survives).
            assert_eq!(back, img, "{w}x{h}x{c}");
        }
    }

    #[test]
    fn grace_latlong_real_file() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/envmaps/grace_latlong.exr");
        let Ok(bytes) = std::fs::read(path) else {
            return crate::test_skip::skip_missing_data(&format!("{path} is missing"));
        };
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height, img.channels), (1024, 512, 3));
        let mut best = (f64::MIN, 0usize, 0usize);
        let mut max_r = f32::MIN;
        for y in 0..img.height {
            for x in 0..img.width {
                let p = img.rgb(x, y);
                let l = crate::maths::colour::rec709_luminance(p);
                if l > best.0 {
                    best = (l, y, x);
                }
                max_r = max_r.max(p[0]);
            }
        }
        // SOURCES.md: brightest pixel at row 382, col 502 as stored (before any flip); R max 18.375.
        assert!(best.1.abs_diff(382) <= 1 && best.2.abs_diff(502) <= 1, "brightest at {best:?}");
        assert!((max_r - 18.375).abs() < 0.01, "max R {max_r}");
        assert!(img.data.iter().all(|v| v.is_finite() && *v >= 0.0));
    }

    #[test]
    fn a_panic_inside_the_decoder_is_the_decoder_panicked_error() {
        let r: Result<(), _> = caught(|| panic!("index out of bounds"), FormatError::DecoderPanicked);
        match r {
            Err(FormatError::DecoderPanicked(m)) => assert_eq!(m, "index out of bounds"),
            other => panic!("{other:?}"),
        }
        let e = caught(|| -> Result<(), _> { panic!("{}", 7) }, FormatError::DecoderPanicked).unwrap_err();
        assert_eq!(e.to_string(), "exr decoder panicked: 7");
        assert!(matches!(caught(|| Ok(3), FormatError::DecoderPanicked), Ok(3)));
    }

    #[test]
    fn garbage_is_an_error() {
        let message = |bytes: &[u8]| decode(bytes).unwrap_err().to_string();
        assert!(message(b"").starts_with("not a readable EXR file"));
        assert_eq!(
            message(b"this is not an exr file at all"),
            "not a readable EXR file: invalid: file identifier missing"
        );
        // The EXR magic number followed by junk.
        let mut f = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        f.extend((0..500u32).map(|i| (i * 37 % 251) as u8));
        assert!(message(&f).starts_with("not a readable EXR file: invalid:"), "{}", message(&f));
        // A valid file cut short.
        let bytes = encode(&test_image(20, 20, 3)).unwrap();
        for n in [0, 4, 8, 40, bytes.len() / 3] {
            let e = message(&bytes[..n]);
            assert!(
                e.starts_with("not a readable EXR file") || e.starts_with("truncated or damaged"),
                "prefix {n}: {e}"
            );
        }
        for n in (0..bytes.len()).step_by(97) {
            let _ = decode(&bytes[..n]); // must not panic through (caught or not)
        }
    }

    #[test]
    fn every_half_value_converts_to_openexrs_float_bits() {
        // OpenEXR (`imath_half_to_float`): zero, subnormals, normals, infinities exact; a NaN
        // keeps its sign and payload shifted by 13 bits, signalling ones included.
        use half::slice::{HalfBitsSliceExt, HalfFloatSliceExt};
        let bits: Vec<u16> = (0..=u16::MAX).collect();
        let mut out = vec![0.0f32; bits.len()];
        bits.reinterpret_cast::<half::f16>().convert_to_f32_slice(&mut out);
        keep_signalling_nans(&bits, &mut out);
        let mut signalling = 0;
        for (&b, &o) in bits.iter().zip(&out) {
            let h = half::f16::from_bits(b);
            if h.is_nan() {
                let want = (b as u32 & 0x8000) << 16 | 0x7f80_0000 | (b as u32 & 0x03ff) << 13;
                assert_eq!(o.to_bits(), want, "half {b:#06x}");
                signalling += is_signalling_nan_half(b) as usize;
            } else {
                assert_eq!(o.to_bits(), h.to_f32().to_bits(), "half {b:#06x}");
            }
        }
        assert_eq!(signalling, 1022);
    }

    #[test]
    fn huge_data_window_refused_before_decoding() {
        let mut bytes = encode(&test_image(4, 4, 3)).unwrap();
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).expect("dataWindow attribute") + key.len() + 4;
        // box2i = xMin, yMin, xMax, yMax (i32 LE): claim 10000 x 10000.
        bytes[at + 8..at + 12].copy_from_slice(&9999i32.to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&9999i32.to_le_bytes());
        let t = std::time::Instant::now();
        // 10000 rows in 16-row ZIP chunks: an offset table of 625 x 8 bytes cannot fit.
        let e = decode(&bytes).unwrap_err().to_string();
        assert!(e.contains("truncated") && e.contains("625 chunks"), "{e}");
        // And beyond MAX_PIXELS.
        bytes[at + 8..at + 12].copy_from_slice(&99999i32.to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&99999i32.to_le_bytes());
        let e = decode(&bytes).unwrap_err().to_string();
        assert_eq!(e, "image too large: 100000x100000 pixels (limit 268435456)");
        assert!(t.elapsed().as_millis() < 1000);
    }

    use ::exr::prelude::{Compression, Image as ExrImage, ImageAttributes, Layer, Text, Vec2};

    fn channel(name: &str, data: Vec<f32>, sampling: usize) -> AnyChannel<FlatSamples> {
        let mut c = AnyChannel::new(name, FlatSamples::F32(data));
        c.sampling = Vec2(sampling, sampling);
        c
    }

    fn decoded(name: &str, values: Vec<f32>, sampling: usize) -> DecodedChannel {
        DecodedChannel { name: name.to_string(), sampling: (sampling, sampling), values }
    }

    fn layer(
        w: usize,
        h: usize,
        name: Option<&str>,
        channels: Vec<AnyChannel<FlatSamples>>,
        compression: Compression,
    ) -> Layer<AnyChannels<FlatSamples>> {
        let attributes = LayerAttributes { layer_name: name.map(Text::from), ..Default::default() };
        let encoding = Encoding { compression, ..Encoding::SMALL_LOSSLESS };
        Layer::new((w, h), attributes, encoding, AnyChannels::sort(SmallVec::from_vec(channels)))
    }

    fn write(image: ExrImage<SmallVec<[Layer<AnyChannels<FlatSamples>>; 2]>>) -> Vec<u8> {
        let mut out = Vec::new();
        image.write().non_parallel().to_buffered(Cursor::new(&mut out)).unwrap();
        out
    }

    fn single(w: usize, h: usize, channels: Vec<AnyChannel<FlatSamples>>, compression: Compression) -> Vec<u8> {
        let l = layer(w, h, None, channels, compression);
        let attrs = ImageAttributes::new(::exr::prelude::IntegerBounds::from_dimensions((w, h)));
        write(ExrImage::from_layers(attrs, SmallVec::from_vec(vec![l])))
    }

    #[test]
    fn luminance_chroma_becomes_rgb_with_openexr_formula() {
        // Constant chroma (so bilinear upsampling is exact), varying luminance.
        let (w, h) = (8usize, 6usize);
        let yw = Primaries::REC709.luminance_weights();
        let rgb = [0.8f64, 0.3, 0.1];
        let y0 = yw[0] * rgb[0] + yw[1] * rgb[1] + yw[2] * rgb[2];
        let scale: Vec<f32> = (0..w * h).map(|i| 0.5 + i as f32 * 0.25).collect();
        let y: Vec<f32> = scale.iter().map(|s| s * y0 as f32).collect();
        let ry = ((rgb[0] - y0) / y0) as f32;
        let by = ((rgb[2] - y0) / y0) as f32;
        // Full-resolution chroma (the exr crate cannot write subsampled channels).
        let chroma = |v: f32| vec![v; w * h];
        let bytes = single(
            w,
            h,
            vec![channel("Y", y.clone(), 1), channel("RY", chroma(ry), 1), channel("BY", chroma(by), 1)],
            Compression::ZIP16,
        );
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height, img.channels), (w, h, 3));
        for (i, s) in scale.iter().enumerate() {
            for (k, c) in rgb.iter().enumerate() {
                let want = *c as f32 * s;
                let got = img.data[i * 3 + k];
                assert!((got - want).abs() <= 1e-4 * want.abs().max(1.0), "pixel {i} channel {k}: {got} vs {want}");
            }
        }
        // RY = BY = 0 is grey Y.
        let bytes = single(
            w,
            h,
            vec![channel("Y", y.clone(), 1), channel("RY", chroma(0.0), 1), channel("BY", chroma(0.0), 1)],
            Compression::ZIP16,
        );
        let img = decode(&bytes).unwrap();
        assert!(img.data.chunks(3).zip(&y).all(|(p, &v)| p == [v, v, v]));
        // Y alone: one channel.
        let img = decode(&single(w, h, vec![channel("Y", y.clone(), 1)], Compression::ZIP16)).unwrap();
        assert_eq!((img.channels, img.data), (1, y));
    }

    #[test]
    fn subsampled_chroma_is_upsampled_bilinearly() {
        // (The exr crate does not write subsampled channels: the plane is built directly. Reading
        // real subsampled files is covered by tests/exr_conformance.rs.)
        let (w, h) = (6usize, 4usize);
        // RY varies along x: samples at x = 0, 2, 4 are 0, 0.2, 0.4; along y: + 1 on row 2.
        let ry: Vec<f32> = (0..(h / 2)).flat_map(|j| [0.0f32, 0.2, 0.4].map(|v| v + j as f32)).collect();
        let plane = full_plane(decoded("RY", ry, 2), w, h).unwrap();
        let want_row = [0.0f32, 0.1, 0.2, 0.3, 0.4, 0.4];
        for y in 0..h {
            let add = [0.0f32, 0.5, 1.0, 1.0][y];
            for x in 0..w {
                assert!((plane[y * w + x] - want_row[x] - add).abs() < 1e-6, "{plane:?}");
            }
        }
        let e = full_plane(decoded("RY", vec![0.0; 5], 2), w, h).unwrap_err().to_string();
        assert_eq!(e, "EXR channel RY has 5 samples for 6x4 pixels at sampling 2x2");
    }

    #[test]
    fn highly_compressible_dwab_file_loads() {
        // A constant 2048 x 1024 RGB image: DWAB packs it far beyond any fixed expansion ratio.
        let (w, h) = (2048usize, 1024usize);
        let channels: Vec<_> = ["R", "G", "B"].iter().map(|n| channel(n, vec![0.25; w * h], 1)).collect();
        let mut l = layer(w, h, None, channels, Compression::DWAB(None));
        for c in l.channel_data.list.iter_mut() {
            if let FlatSamples::F32(v) = &c.sample_data {
                c.sample_data = FlatSamples::F16(v.iter().map(|&x| ::exr::prelude::f16::from_f32(x)).collect());
            }
        }
        let attrs = ImageAttributes::new(::exr::prelude::IntegerBounds::from_dimensions((w, h)));
        let bytes = write(ExrImage::from_layers(attrs, SmallVec::from_vec(vec![l])));
        let ratio = (w * h * 3 * 2) as f64 / bytes.len() as f64;
        assert!(ratio > 2000.0, "only {ratio:.0}:1 ({} bytes)", bytes.len());
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height), (w, h));
        assert!(img.data.iter().all(|&v| (v - 0.25).abs() < 1e-3));
    }

    fn multipart() -> Vec<u8> {
        let (w, h) = (4usize, 3usize);
        let depth = layer(w, h, Some("depth"), vec![channel("Z", vec![7.0; w * h], 1)], Compression::ZIP16);
        let rgb = layer(
            w,
            h,
            Some("beauty"),
            vec![
                channel("R", vec![1.0; w * h], 1),
                channel("G", vec![2.0; w * h], 1),
                channel("B", vec![3.0; w * h], 1),
            ],
            Compression::ZIP16,
        );
        let diffuse = layer(
            w,
            h,
            Some("aovs"),
            vec![
                channel("diffuse.R", vec![4.0; w * h], 1),
                channel("diffuse.G", vec![5.0; w * h], 1),
                channel("diffuse.B", vec![6.0; w * h], 1),
                channel("spec.R", vec![8.0; w * h], 1),
                channel("spec.G", vec![9.0; w * h], 1),
                channel("spec.B", vec![10.0; w * h], 1),
            ],
            Compression::ZIP16,
        );
        let attrs = ImageAttributes::new(::exr::prelude::IntegerBounds::from_dimensions((w, h)));
        write(ExrImage::from_layers(attrs, SmallVec::from_vec(vec![depth, rgb, diffuse])))
    }

    #[test]
    fn multipart_picks_first_colour_part_or_the_chosen_one() {
        let bytes = multipart();
        let first = |img: Image| img.data[..3].to_vec();
        assert_eq!(first(decode(&bytes).unwrap()), [1.0, 2.0, 3.0]);
        let with = |part: Option<usize>, layer: Option<&str>| {
            decode_with(&bytes, &DecodeOptions { part, layer: layer.map(str::to_string), ..Default::default() })
        };
        let e = with(Some(0), None).unwrap_err().to_string();
        assert!(e.contains("part 0") && e.contains("Z"), "{e}");
        assert_eq!(first(with(Some(1), None).unwrap()), [1.0, 2.0, 3.0]);
        assert_eq!(first(with(None, Some("beauty")).unwrap()), [1.0, 2.0, 3.0]);
        assert_eq!(first(with(None, Some("diffuse")).unwrap()), [4.0, 5.0, 6.0]);
        assert_eq!(first(with(Some(2), Some("spec")).unwrap()), [8.0, 9.0, 10.0]);
        assert!(with(Some(5), None).unwrap_err().to_string().contains("no part 5"));
        assert!(with(None, Some("nope")).unwrap_err().to_string().contains("\"nope\""));
        let depth_only = single(2, 2, vec![channel("Z", vec![1.0; 4], 1)], Compression::ZIP16);
        let e = decode(&depth_only).unwrap_err().to_string();
        assert!(e.contains("no part with a colour channel") && e.contains("Z"), "{e}");
    }

    #[test]
    fn flat_file_whose_type_says_deep_is_read() {
        let img = test_image(5, 4, 3);
        let bytes = encode(&img).unwrap();
        // Put `type = "deepscanline"` in the header (replacing a `type` the writer put there,
        // else before the header's terminating null byte), and shift the offset table.
        let end = headers_end(&bytes, false).unwrap();
        let key = b"type\0string\0";
        let (at, cut) = match bytes.windows(key.len()).position(|w| w == key) {
            Some(at) => {
                let n = i32::from_le_bytes(bytes[at + key.len()..at + key.len() + 4].try_into().unwrap()) as usize;
                (at, key.len() + 4 + n)
            }
            None => (end - 1, 0),
        };
        let mut attr = key.to_vec();
        attr.extend_from_slice(&12i32.to_le_bytes());
        attr.extend_from_slice(b"deepscanline");
        let mut bad = bytes[..at].to_vec();
        bad.extend_from_slice(&attr);
        bad.extend_from_slice(&bytes[at + cut..]);
        let chunks = read_meta(&bytes).unwrap().headers[0].chunk_count;
        let shift = attr.len() as i64 - cut as i64;
        let table = (end as i64 + shift) as usize;
        for i in 0..chunks {
            let slot = &mut bad[table + 8 * i..table + 8 * i + 8];
            let v = u64::from_le_bytes((&*slot).try_into().unwrap()) as i64 + shift;
            slot.copy_from_slice(&(v as u64).to_le_bytes());
        }
        assert!(read_meta(&bad).unwrap().headers[0].deep);
        assert_eq!(decode(&bad).unwrap(), img);
    }

    #[test]
    fn display_window_and_colorspace() {
        let (w, h) = (3usize, 2usize);
        // XYZ of D65 white.
        let d65 = [0.3127f32 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];
        let channels = ["R", "G", "B"].iter().zip(d65).map(|(n, v)| channel(n, vec![v; w * h], 1)).collect::<Vec<_>>();
        let mut l = layer(w, h, None, channels, Compression::ZIP16);
        l.attributes.layer_position = Vec2(2, 1);
        let mut attrs = ImageAttributes::new(::exr::prelude::IntegerBounds::new((0, 0), (4, 4)));
        // XYZ primaries: R = X, G = Y, B = Z, white E.
        attrs.chromaticities = Some(Chromaticities {
            red: Vec2(1.0, 0.0),
            green: Vec2(0.0, 1.0),
            blue: Vec2(0.0, 0.0),
            white: Vec2(1.0 / 3.0, 1.0 / 3.0),
        });
        let bytes = write(ExrImage::from_layers(attrs, SmallVec::from_vec(vec![l])));
        let raw = DecodeOptions { colorspace: ColorSpace::AsStored, ..Default::default() };
        let img = decode_with(&bytes, &raw).unwrap();
        assert_eq!((img.width, img.height), (4, 4));
        for y in 0..4 {
            for x in 0..4 {
                let inside = (2..4).contains(&x) && (1..3).contains(&y);
                assert_eq!(img.rgb(x, y), if inside { d65 } else { [0.0; 3] }, "({x}, {y})");
            }
        }
        assert_eq!(header_size(&bytes, &raw), Some((4, 4)));
        let data = DecodeOptions { window: Window::Data, ..raw.clone() };
        let img = decode_with(&bytes, &data).unwrap();
        assert_eq!((img.width, img.height), (3, 2));
        assert_eq!(header_size(&bytes, &data), Some((3, 2)));
        // Linear709: the XYZ of D65 white is Rec. 709 white (1, 1, 1).
        let img = decode_with(&bytes, &DecodeOptions { window: Window::Data, ..Default::default() }).unwrap();
        for v in &img.data {
            assert!((v - 1.0).abs() < 2e-3, "{:?}", img.data);
        }
    }

    #[test]
    fn every_compression_and_half_round_trip_with_alpha_and_names() {
        let (w, h) = (40usize, 37usize);
        let mut img = test_image(w, h, 4);
        // Smooth values within half range (DWAA is lossy on half colour channels).
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = 0.5 + 0.25 * ((i / 4 % w) as f32 * 0.1).sin() + 0.01 * (i % 4) as f32;
        }
        for compression in [ExrCompression::Zip, ExrCompression::Piz, ExrCompression::Dwaa, ExrCompression::None] {
            for half in [false, true] {
                let o = EncodeOptions { compression, half };
                let bytes = encode_with(&img, &o).unwrap();
                let meta = read_meta(&bytes).unwrap();
                let header = &meta.headers[0];
                let want = match compression {
                    ExrCompression::Zip => Compression::ZIP16,
                    ExrCompression::Piz => Compression::PIZ,
                    ExrCompression::Dwaa => Compression::DWAA(None),
                    ExrCompression::None => Compression::Uncompressed,
                };
                assert_eq!(header.compression.to_string(), want.to_string(), "{o:?}");
                let types: Vec<SampleType> = header.channels.list.iter().map(|c| c.sample_type).collect();
                assert!(types.iter().all(|&t| t == if half { SampleType::F16 } else { SampleType::F32 }), "{o:?}");
                let back = decode(&bytes).unwrap();
                assert_eq!(back.names, ["R", "G", "B", "A"], "{o:?}");
                let tol = match (compression, half) {
                    // Lossy, f32 channels too in the exr crate (measured 1.6e-3 at values ~0.5).
                    (ExrCompression::Dwaa, _) => 0.02,
                    (_, true) => 1e-3,
                    _ => 0.0,
                };
                let worst = back.data.iter().zip(&img.data).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
                assert!(worst <= tol, "{o:?}: worst error {worst}");
            }
        }
        // Other channel names are kept (a depth map).
        let mut z = test_image(5, 3, 1);
        z.names = vec!["Z".into()];
        let meta =
            read_meta(&encode_with(&z, &EncodeOptions { compression: ExrCompression::Piz, half: true }).unwrap())
                .unwrap();
        assert_eq!(meta.headers[0].channels.list[0].name.to_string(), "Z");
    }
}
