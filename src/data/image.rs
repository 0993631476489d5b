//! `Image`: a float raster, row-major, row 0 at the top, 1 (scalar field) or 3 (RGB) channels.
//!
//! Values are linear radiance as stored in the source file (no transfer curve); f32 in memory,
//! f64 wherever we sum many of them (see `../shared/NOTES.md`: a sun can exceed half-float range).

/// A float raster. `data.len() == width * height * channels`, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// 1 for a scalar field (luminance, masks), 3 for RGB.
    pub channels: usize,
    pub data: Vec<f32>,
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Image { width, height, channels, data: vec![0.0; width * height * channels] }
    }

    /// Wraps `data`; panics if the length does not match (a broken invariant, never user input).
    pub fn from_vec(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Self {
        assert_eq!(data.len(), width * height * channels, "image buffer size mismatch");
        Image { width, height, channels, data }
    }

    /// Builds an RGB image from a function of (x, y).
    pub fn from_fn_rgb(width: usize, height: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> Self {
        let mut data = Vec::with_capacity(width * height * 3);
        for y in 0..height {
            for x in 0..width {
                data.extend_from_slice(&f(x, y));
            }
        }
        Image { width, height, channels: 3, data }
    }

    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }

    /// The channels of pixel (x, y).
    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }

    #[inline]
    pub fn pixel_mut(&mut self, x: usize, y: usize) -> &mut [f32] {
        let i = (y * self.width + x) * self.channels;
        &mut self.data[i..i + self.channels]
    }

    /// Pixel (x, y) as RGB: a scalar field is replicated to grey.
    #[inline]
    pub fn rgb(&self, x: usize, y: usize) -> [f32; 3] {
        let p = self.pixel(x, y);
        if self.channels == 1 {
            [p[0], p[0], p[0]]
        } else {
            [p[0], p[1], p[2]]
        }
    }

    /// One row's samples (width * channels floats).
    #[inline]
    pub fn row(&self, y: usize) -> &[f32] {
        let n = self.width * self.channels;
        &self.data[y * n..(y + 1) * n]
    }

    /// The same image with rows in reverse order.
    pub fn flipped_vertical(&self) -> Image {
        let n = self.width * self.channels;
        let mut data = Vec::with_capacity(self.data.len());
        for y in (0..self.height).rev() {
            data.extend_from_slice(&self.data[y * n..(y + 1) * n]);
        }
        Image { data, ..*self }
    }
}
