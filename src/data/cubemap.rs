//! `Cubemap`: six square RGB f32 faces in the order +X, -X, +Y, -Y, +Z, -Z (the OpenGL / KTX
//! order; face axes in [`crate::geometry::cubemap`]), and `MipChain`: a list of cube maps, level
//! k of size max(1, size >> k), with the perceptual roughness each level was filtered for.

use crate::data::Image;
use crate::geometry::cubemap as cube;
use glam::DVec3;

/// Six S x S RGB faces, face by face, row by row (row 0 at the top of each face), 3 floats per
/// texel: `data.len() == 6 * size * size * 3`.
#[derive(Clone, Debug, PartialEq)]
pub struct Cubemap {
    pub size: usize,
    pub data: Vec<f32>,
}

impl Cubemap {
    /// A black cube map of face size `size`.
    pub fn new(size: usize) -> Self {
        Cubemap { size, data: vec![0.0; 6 * size * size * 3] }
    }

    /// A cube map of face size `size` whose texel (face, x, y) is `f(face, x, y)`, rows in
    /// parallel: the loop every resampler and filter over cube texels shares.
    pub fn from_fn(size: usize, f: impl Fn(usize, usize, usize) -> [f32; 3] + Sync) -> Self {
        use rayon::prelude::*;
        let mut out = Cubemap::new(size);
        out.data.par_chunks_mut(3 * size.max(1)).enumerate().for_each(|(row, texels)| {
            let (face, y) = (row / size, row % size);
            for x in 0..size {
                texels[3 * x..3 * x + 3].copy_from_slice(&f(face, x, y));
            }
        });
        out
    }

    /// Number of texels (6 S^2).
    pub fn texel_count(&self) -> usize {
        6 * self.size * self.size
    }

    /// Texel `i` (flat index `(face * S + y) * S + x`) as RGB.
    #[inline]
    pub fn texel(&self, i: usize) -> [f32; 3] {
        [self.data[3 * i], self.data[3 * i + 1], self.data[3 * i + 2]]
    }

    /// The texel containing direction `d`, as RGB (nearest texel).
    #[inline]
    pub fn lookup(&self, d: DVec3) -> [f32; 3] {
        self.texel(cube::texel_index_of_direction(d, self.size))
    }

    /// The six faces side by side as one 6S x S RGB image (+X first): the strip `Save` writes.
    pub fn to_strip(&self) -> Image {
        let s = self.size;
        let mut data = Vec::with_capacity(self.data.len());
        for y in 0..s {
            for f in 0..6 {
                let start = ((f * s + y) * s) * 3;
                data.extend_from_slice(&self.data[start..start + 3 * s]);
            }
        }
        Image::from_vec(6 * s, s, 3, data)
    }

    /// The cube map of a 6S x S strip (the inverse of `to_strip`); `None` unless the image is
    /// six squares wide with at least 3 channels (RGB first) or one (grey).
    pub fn from_strip(img: &Image) -> Option<Cubemap> {
        let s = img.height;
        if s == 0 || img.width != 6 * s {
            return None;
        }
        let mut out = Cubemap::new(s);
        for f in 0..6 {
            for y in 0..s {
                for x in 0..s {
                    let rgb = img.rgb(f * s + x, y);
                    let i = (f * s + y) * s + x;
                    out.data[3 * i..3 * i + 3].copy_from_slice(&rgb);
                }
            }
        }
        Some(out)
    }

    /// Whether every value is finite.
    pub fn is_finite(&self) -> bool {
        self.data.iter().all(|v| v.is_finite())
    }
}

/// A prefiltered chain: level k is a cube map of size max(1, size >> k), filtered for the
/// perceptual roughness `roughness[k]` (alpha = roughness^2).
#[derive(Clone, Debug, PartialEq)]
pub struct MipChain {
    pub levels: Vec<Cubemap>,
    pub roughness: Vec<f64>,
}
