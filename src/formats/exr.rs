//! OpenEXR (`.exr`) through the `exr` crate (pure Rust, 1.74: reads every standard compression,
//! DWAA/DWAB included), from and to memory.
//!
//! # Reading
//!
//! 1. **Meta data first.** Only the headers are parsed (`MetaData::read_from_buffered`), and a
//!    data window with more than [`MAX_PIXELS`] pixels, or with `W * H * channels * 2` bytes
//!    (half floats) beyond `bytes.len() * 2000 + 1 MiB`, is refused before any pixel is
//!    decoded. Why 2000: deflate (ZIP/ZIPS) cannot expand more than about 1032:1 (RFC 1951: a
//!    258-byte match costs at least 2 bits), and the other EXR codecs are bounded similarly or
//!    worse (RLE 128:1); 2000 leaves margin, the 1 MiB covers tiny files. Without this check a
//!    40-byte header could make the decoder allocate gigabytes.
//! 2. **Pixels.** The first non-deep layer at its largest resolution level, all channels; `R`,
//!    `G`, `B` (and `A`, kept as a fourth channel) are picked by name whatever their stored order
//!    (EXR stores channels sorted by name, so `grace_latlong.exr` has B, G, R) and whatever their
//!    sample type (f16, f32 or u32, all converted to f32). Other channels are ignored. With no R/G/B but a `Y` channel
//!    the result has 1 channel. A layer-prefixed name (`diffuse.R`) is accepted when there is no
//!    bare one. If only some of R/G/B exist, the missing ones are 0.
//! 3. **Orientation.** EXR rows run top to bottom of the data window (y grows downwards), like
//!    ours; nothing is flipped. (`grace_latlong.exr` is itself stored upside-down, row 0 = straight
//!    down: `../shared/data/envmaps/SOURCES.md`. Flipping it is the caller's decision.)
//!
//! Errors from the `exr` crate become [`FormatError`]s carrying their text. As a belt-and-braces
//! guard against panics on hostile input inside the dependency, the whole decode runs under
//! `std::panic::catch_unwind`, and a panic becomes `FormatError("exr decoder panicked: ...")`.
//!
//! # Writing
//!
//! [`encode`]: one layer of f32 `R`, `G`, `B` (or `Y` for 1 channel), ZIP compression (16-line
//! blocks, OpenEXR's `ZIP_COMPRESSION`), scanlines, increasing Y. f32 rather than half because real
//! suns exceed the half-float maximum 65504 (`../shared/NOTES.md`).

use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};

use ::exr::prelude::traits::*;
use ::exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, LayerAttributes, MetaData, SmallVec};

use super::{FormatError, MAX_PIXELS};
use crate::data::Image;

/// Maximum expansion ratio assumed for any EXR compression (deflate's is ~1032:1).
const MAX_EXPANSION: u128 = 2000;

/// Images smaller than this many pixels are read and written on the calling thread: the `exr`
/// crate builds a thread pool per parallel call, which costs more than it saves on small images.
const PARALLEL_MIN_PIXELS: usize = 1 << 16;

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Decodes an OpenEXR file from memory (see the module docs).
pub fn decode(bytes: &[u8]) -> Result<Image, FormatError> {
    match catch_unwind(AssertUnwindSafe(|| decode_inner(bytes))) {
        Ok(result) => result,
        Err(payload) => Err(FormatError(format!("exr decoder panicked: {}", panic_message(&*payload)))),
    }
}

fn decode_inner(bytes: &[u8]) -> Result<Image, FormatError> {
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| FormatError(format!("not a readable EXR file: {e}")))?;
    if meta.headers.is_empty() {
        return Err(FormatError("EXR file has no layers".into()));
    }
    let mut largest = 0usize;
    for header in meta.headers.iter() {
        let (w, h) = (header.layer_size.0, header.layer_size.1);
        let pixels = w
            .checked_mul(h)
            .filter(|&p| p <= MAX_PIXELS)
            .ok_or_else(|| FormatError(format!("image too large: {w}x{h} pixels (limit {MAX_PIXELS})")))?;
        let channels = header.channels.list.len();
        let claimed = pixels as u128 * channels as u128 * 2;
        let possible = bytes.len() as u128 * MAX_EXPANSION + (1 << 20);
        if claimed > possible {
            return Err(FormatError(format!(
                "truncated: header claims {w}x{h} pixels x {channels} channels but only {} bytes \
                 follow (more than any EXR compression can expand)",
                bytes.len()
            )));
        }
        largest = largest.max(pixels);
    }
    if meta.headers.iter().all(|h| h.deep) {
        return Err(FormatError("deep-data EXR files are not supported".into()));
    }

    let mut reader = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes();
    if largest < PARALLEL_MIN_PIXELS {
        reader = reader.non_parallel();
    }
    let image =
        reader.from_buffered(Cursor::new(bytes)).map_err(|e| FormatError(format!("EXR decoding failed: {e}")))?;

    let layer = image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let pixels = w
        .checked_mul(h)
        .filter(|&p| p > 0 && p <= MAX_PIXELS)
        .ok_or_else(|| FormatError(format!("bad EXR layer size {w}x{h}")))?;
    let list = &layer.channel_data.list;
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    let find = |want: &str| -> Option<usize> {
        names.iter().position(|n| n == want).or_else(|| {
            let suffix = format!(".{want}");
            names.iter().position(|n| n.ends_with(&suffix))
        })
    };
    // One channel's samples as f32 (None for an absent channel).
    let plane = |index: Option<usize>| -> Result<Option<Vec<f32>>, FormatError> {
        let Some(i) = index else { return Ok(None) };
        let samples = &list[i].sample_data;
        if samples.len() != pixels {
            return Err(FormatError(format!(
                "EXR channel {} has {} samples for {w}x{h} pixels (subsampled channels are not supported)",
                names[i],
                samples.len()
            )));
        }
        Ok(Some(match samples {
            FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
        }))
    };

    let (ri, gi, bi) = (find("R"), find("G"), find("B"));
    if ri.is_some() || gi.is_some() || bi.is_some() {
        let (r, g, b) = (plane(ri)?, plane(gi)?, plane(bi)?);
        // Alpha travels with the colour (named `A`, or `layer.A` beside `layer.R`).
        let a = plane(find("A"))?;
        let c = if a.is_some() { 4 } else { 3 };
        let get = |p: &Option<Vec<f32>>, i: usize| p.as_ref().map_or(0.0, |v| v[i]);
        let mut data = Vec::with_capacity(pixels * c);
        for i in 0..pixels {
            data.push(get(&r, i));
            data.push(get(&g, i));
            data.push(get(&b, i));
            if let Some(a) = &a {
                data.push(a[i]);
            }
        }
        return Ok(Image::from_vec(w, h, c, data));
    }
    if let Some(y) = plane(find("Y"))? {
        return Ok(Image::from_vec(w, h, 1, y));
    }
    Err(FormatError(format!(
        "EXR layer has no R, G, B or Y channel (channels: {})",
        if names.is_empty() { "none".to_string() } else { names.join(", ") }
    )))
}

/// Encodes `image` as a ZIP-compressed float32 OpenEXR file, one EXR channel per image channel
/// under the image's channel names (`R G B`, `R G B A`, `Y`, `Z`, ...).
pub fn encode(image: &Image) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    if w == 0 || h == 0 {
        return Err(FormatError(format!("cannot write an empty {w}x{h} image as EXR")));
    }
    if c == 0 || image.names.len() != c {
        return Err(FormatError(format!(
            "cannot write an image with {c} channels and {} names as EXR",
            image.names.len()
        )));
    }
    let mut sorted = image.names.clone();
    sorted.sort();
    sorted.dedup();
    if sorted.len() != c || sorted.iter().any(|n| n.is_empty()) {
        return Err(FormatError(format!("EXR channel names must be unique and non-empty: {:?}", image.names)));
    }
    let pixels = w * h;
    if image.data.len() != pixels * c {
        return Err(FormatError(format!("image buffer has {} samples, expected {w}x{h}x{c}", image.data.len())));
    }
    match catch_unwind(AssertUnwindSafe(|| encode_inner(image))) {
        Ok(result) => result,
        Err(payload) => Err(FormatError(format!("exr encoder panicked: {}", panic_message(&*payload)))),
    }
}

fn encode_inner(image: &Image) -> Result<Vec<u8>, FormatError> {
    let (w, h, c) = (image.width, image.height, image.channels);
    let list: Vec<AnyChannel<FlatSamples>> = if c == 1 {
        vec![AnyChannel::new(image.names[0].as_str(), FlatSamples::F32(image.data.clone()))]
    } else {
        let plane = |k: usize| -> Vec<f32> { image.data.chunks_exact(c).map(|p| p[k]).collect() };
        (0..c).map(|k| AnyChannel::new(image.names[k].as_str(), FlatSamples::F32(plane(k)))).collect()
    };
    let channels = AnyChannels::sort(SmallVec::from_vec(list));
    // SMALL_LOSSLESS = ZIP (16 scanlines per block), scanline blocks, increasing Y.
    let layer = ::exr::prelude::Layer::new((w, h), LayerAttributes::default(), Encoding::SMALL_LOSSLESS, channels);
    let exr_image = ::exr::prelude::Image::from_layer(layer);
    let mut out: Vec<u8> = Vec::new();
    let writer = exr_image.write();
    let writer = if w * h < PARALLEL_MIN_PIXELS { writer.non_parallel() } else { writer };
    writer.to_buffered(Cursor::new(&mut out)).map_err(|e| FormatError(format!("EXR encoding failed: {e}")))?;
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
            eprintln!("SKIPPED: {path} is missing");
            return;
        };
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height, img.channels), (1024, 512, 3));
        let mut best = (f64::MIN, 0usize, 0usize);
        let mut max_r = f32::MIN;
        for y in 0..img.height {
            for x in 0..img.width {
                let p = img.rgb(x, y);
                let l = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
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
    fn garbage_is_an_error() {
        assert!(decode(b"").is_err());
        assert!(decode(b"this is not an exr file at all").is_err());
        // The EXR magic number followed by junk.
        let mut f = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        f.extend((0..500u32).map(|i| (i * 37 % 251) as u8));
        assert!(decode(&f).is_err());
        // A valid file cut short.
        let bytes = encode(&test_image(20, 20, 3)).unwrap();
        for n in [0, 4, 8, 40, bytes.len() / 3] {
            assert!(decode(&bytes[..n]).is_err(), "prefix {n}");
        }
        for n in (0..bytes.len()).step_by(97) {
            let _ = decode(&bytes[..n]); // must not panic through (caught or not)
        }
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
        let e = decode(&bytes).unwrap_err().0;
        assert!(e.contains("10000x10000"), "{e}");
        // And beyond MAX_PIXELS.
        bytes[at + 8..at + 12].copy_from_slice(&99999i32.to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&99999i32.to_le_bytes());
        assert!(decode(&bytes).is_err());
        assert!(t.elapsed().as_millis() < 1000);
    }
}
