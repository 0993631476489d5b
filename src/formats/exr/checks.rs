//! What an EXR file's headers imply, checked before anything is allocated: the header bytes
//! end where they say, the sizes fit `MAX_PIXELS`, and a deep part of the wrong type is dropped
//! rather than handed to the decoder.

use std::io::Cursor;

use ::exr::meta::attribute::SampleType;
use ::exr::prelude::MetaData;

use super::MAX_DECODED_BYTES;
use crate::formats::{FormatError, Window, MAX_PIXELS};

pub(super) fn read_meta(bytes: &[u8]) -> Result<MetaData, FormatError> {
    MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| FormatError::Invalid(format!("not a readable EXR file: {e}")))
}

/// The byte position just past the header(s), where the chunk offset tables start.
pub(super) fn headers_end(bytes: &[u8], multipart: bool) -> Option<usize> {
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
pub(super) fn drop_wrong_deep_type(bytes: &[u8], meta: &MetaData) -> Option<Vec<u8>> {
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

pub(super) fn sample_bytes(t: SampleType) -> u128 {
    match t {
        SampleType::F16 => 2,
        SampleType::F32 | SampleType::U32 => 4,
    }
}

/// The size checks of the module docs (before any pixel is decoded).
pub(super) fn check_sizes(bytes: &[u8], meta: &MetaData, window: Window) -> Result<usize, FormatError> {
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
