//! Reading the rendered frame back and deciding when it is final.
//!
//! Bevy compiles pipelines and uploads the cube maps over the first frames, and a mesh whose
//! pipeline is not ready is skipped, so early frames can be empty or lack the environment light.
//! The frame is taken when it has been identical (bit for bit) for [`STABLE_FRAMES`] readbacks
//! in a row, at least [`MIN_FRAMES`] frames in, with every sphere's centre pixel covered (alpha
//! > 0; the background is cleared to alpha 0), or for a skybox the centre and the four corners. Lavapipe renders deterministically, so a settled
//! frame repeats exactly.

use bevy::prelude::*;
use bevy::render::gpu_readback::ReadbackComplete;

use crate::scene::{SPHERES, VIEW_WIDTH, centre_x};

/// Identical consecutive readbacks needed.
pub const STABLE_FRAMES: usize = 3;
/// Frames rendered before any readback counts.
pub const MIN_FRAMES: usize = 8;

/// What the readback observer has seen so far.
#[derive(Resource, Default)]
pub struct Frames {
    /// readbacks received
    pub count: usize,
    /// the last readback's pixels (RGBA f32, rows unpadded) and how many times in a row it came
    pub last: Option<(Vec<f32>, usize)>,
}

/// The frame's size, for unpadding rows.
#[derive(Resource, Clone, Copy)]
pub struct FrameSize {
    pub width: u32,
    pub height: u32,
}

/// Observer of `ReadbackComplete`: strips the row padding (rows are aligned to 256 bytes) and
/// counts repeats.
pub fn on_readback(ev: On<ReadbackComplete>, size: Res<FrameSize>, mut frames: ResMut<Frames>) {
    let (w, h) = (size.width as usize, size.height as usize);
    let row = w * 16;
    let padded = if h > 0 { ev.data.len() / h } else { 0 };
    if padded < row {
        warn!("readback of {} bytes is too small for {w}x{h} RGBA32F", ev.data.len());
        return;
    }
    let mut pixels = Vec::with_capacity(w * h * 4);
    for y in 0..h {
        let bytes = &ev.data[y * padded..y * padded + row];
        pixels.extend(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
    }
    frames.count += 1;
    let repeats = match &frames.last {
        Some((prev, n)) if prev.iter().map(|v| v.to_bits()).eq(pixels.iter().map(|v| v.to_bits())) => n + 1,
        _ => 1,
    };
    frames.last = Some((pixels, repeats));
}

/// Whether every sphere's centre pixel is covered (alpha > 0).
pub fn spheres_covered(pixels: &[f32], size: FrameSize) -> bool {
    let (w, h) = (size.width as usize, size.height as usize);
    let px_per_unit = w as f32 / VIEW_WIDTH;
    (0..SPHERES.len()).all(|k| {
        let i = ((centre_x(k) + VIEW_WIDTH / 2.0) * px_per_unit) as usize;
        let j = h / 2;
        i < w && pixels.get((j * w + i) * 4 + 3).is_some_and(|&a| a > 0.0)
    })
}

/// Whether the skybox covers the frame's centre and corners (alpha > 0).
pub fn sky_covered(pixels: &[f32], size: FrameSize) -> bool {
    let (w, h) = (size.width as usize, size.height as usize);
    [(w / 2, h / 2), (0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]
        .iter()
        .all(|&(i, j)| pixels.get((j * w + i) * 4 + 3).is_some_and(|&a| a > 0.0))
}

/// The settled frame, if there is one yet (`skybox`: the frame is a skybox, not the spheres).
pub fn settled(frames: &Frames, size: FrameSize, skybox: bool) -> Option<&[f32]> {
    match &frames.last {
        Some((pixels, n))
            if *n >= STABLE_FRAMES
                && frames.count >= MIN_FRAMES
                && if skybox { sky_covered(pixels, size) } else { spheres_covered(pixels, size) } =>
        {
            Some(pixels)
        }
        _ => None,
    }
}

/// Writes RGBA f32 pixels (row 0 at the top) as a scan-line EXR (f32 channels R, G, B, A).
pub fn write_exr(path: &std::path::Path, pixels: &[f32], size: FrameSize) -> Result<(), String> {
    let w = size.width as usize;
    exr::prelude::write_rgba_file(path, w, size.height as usize, |x, y| {
        let p = &pixels[(y * w + x) * 4..(y * w + x) * 4 + 4];
        (p[0], p[1], p[2], p[3])
    })
    .map_err(|e| format!("cannot write {}: {e}", path.display()))
}
