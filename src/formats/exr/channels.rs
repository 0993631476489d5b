//! Reading one part's channels into planes and interleaving them into an [`Image`], keeping
//! signalling NaNs and placing the data window inside the display window.

use std::io::Cursor;

use ::exr::meta::attribute::{IntegerBounds, SampleType};

use crate::formats::FormatError;
use crate::values::Image;

/// One channel of the chosen part as decoded: f32 samples in the channel's own sample grid
/// (`width / sampling.0` x `height / sampling.1`).
#[derive(Default)]
pub(super) struct DecodedChannel {
    pub(super) name: String,
    pub(super) sampling: (usize, usize),
    pub(super) values: Vec<f32>,
}

/// Decodes the largest resolution level of part `part` only, through the `exr` crate's block
/// API: the other parts' chunks (deep ones included) are never read. The part is cut into
/// horizontal bands (a scan line block's rows, or a row of tiles), and the bands are decoded in
/// parallel on our rayon pool straight into each channel's plane (the crate's image reader
/// builds a thread pool per call, decodes every part, and copies each line once more).
pub(super) fn read_part(
    bytes: &[u8],
    part: usize,
    parallel: bool,
) -> Result<(usize, usize, Vec<DecodedChannel>), FormatError> {
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
pub(super) fn is_signalling_nan_half(b: u16) -> bool {
    b & 0x7e00 == 0x7c00 && b & 0x01ff != 0
}

/// OpenEXR converts half to float by shifting the bits (`imath_half_to_float`), so a signalling
/// NaN stays signalling with its payload; the `half` crate, and F16C, set the quiet bit. The value
/// is NaN either way, but not the same bits as OpenEXR (the OpenEXR test image `AllHalfValues.exr`
/// holds all 1022 of them): redo those samples as OpenEXR does. Lines without one (nearly all)
/// cost one vectorised scan.
pub(super) fn keep_signalling_nans(bits: &[u16], out: &mut [f32]) {
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
pub(super) fn full_plane(channel: DecodedChannel, w: usize, h: usize) -> Result<Vec<f32>, FormatError> {
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

/// Interleaves planes (absent ones skipped): `[R, G, B, A]` or `[Y]`.
pub(super) fn interleave(planes: &[Option<Vec<f32>>]) -> (Vec<f32>, usize) {
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
pub(super) fn place(image: Image, origin: (i64, i64), display: IntegerBounds) -> Image {
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
