//! `Image`: a float raster, row-major, row 0 at the top, with any number of named channels; in
//! graphs an `image` (2+ channels) or a `scalar field` (1 channel): the type follows the channel
//! count, so an operator can demand a one-channel input at validation.
//!
//! Values are linear radiance as stored in the source file (no transfer curve); f32 in memory,
//! f64 wherever we sum many of them (see `../shared/NOTES.md`: a sun can exceed half-float range).
//! Channels are interleaved per pixel in the order of `names`. Colour images keep `R, G, B`
//! first (then `A` or anything else), so that `rgb()` reads the first three channels.
//!
//! A folder so that the type stays below the file formats that read and write it: this file
//! holds the type and its methods (`crate::formats` builds on it), [`codec`] its `TypeSpec`s and
//! cache payload. How `Save` writes it is `crate::formats::save::image`.

pub mod codec;

pub use codec::{IMAGE, SCALAR_FIELD};

/// A float raster. `data.len() == width * height * channels`, rows top to bottom.
/// The fields are public: the samples are the type's API, which operators and file formats read
/// and write in place (a copy of a map would double its memory); the constructors check the
/// lengths, and the codec checks a decoded entry's.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// The number of channels per pixel (`names.len()`): 1 for a scalar field, 3 for RGB, ...
    pub channels: usize,
    /// One name per channel, e.g. `Y`, `R G B`, `R G B A`, `Z`.
    pub names: Vec<String>,
    pub data: Vec<f32>,
}

/// The conventional channel names for a channel count: `Y`, `Y A`, `R G B`, `R G B A`, else
/// `C0 C1 ...`.
pub fn default_names(channels: usize) -> Vec<String> {
    let names: &[&str] = match channels {
        1 => &["Y"],
        2 => &["Y", "A"],
        3 => &["R", "G", "B"],
        4 => &["R", "G", "B", "A"],
        _ => return (0..channels).map(|i| format!("C{i}")).collect(),
    };
    names.iter().map(|s| s.to_string()).collect()
}

impl Image {
    /// A black image with the conventional channel names.
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Image { width, height, channels, names: default_names(channels), data: vec![0.0; width * height * channels] }
    }

    /// Wraps `data` with the conventional channel names; panics if the length does not match
    /// (a broken invariant, never user input).
    pub fn from_vec(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Self {
        assert_eq!(data.len(), width * height * channels, "image buffer size mismatch");
        Image { width, height, channels, names: default_names(channels), data }
    }

    /// Wraps `data` with the given channel names (one per channel).
    pub fn with_names(width: usize, height: usize, names: Vec<String>, data: Vec<f32>) -> Self {
        let channels = names.len();
        assert_eq!(data.len(), width * height * channels, "image buffer size mismatch");
        Image { width, height, channels, names, data }
    }

    /// Builds an RGB image from a function of (x, y).
    pub fn from_fn_rgb(width: usize, height: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> Self {
        let mut data = Vec::with_capacity(width * height * 3);
        for y in 0..height {
            for x in 0..width {
                data.extend_from_slice(&f(x, y));
            }
        }
        Image::from_vec(width, height, 3, data)
    }

    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }

    /// The index of the channel named `name`.
    pub fn channel_index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// One channel as its own one-channel image, named like the channel.
    pub fn channel(&self, index: usize) -> Image {
        let data = self.data.iter().skip(index).step_by(self.channels).copied().collect();
        Image::with_names(self.width, self.height, vec![self.names[index].clone()], data)
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

    /// Pixel (x, y) as RGB: the first three channels; one channel is replicated to grey, as is
    /// one with an alpha (`Y A`: the alpha is ignored); two colour channels (`R G`, e.g. a BRDF
    /// table's scale and bias) are (R, G, 0).
    #[inline]
    pub fn rgb(&self, x: usize, y: usize) -> [f32; 3] {
        let p = self.pixel(x, y);
        match self.channels {
            1 => [p[0], p[0], p[0]],
            2 if self.names[1] == "A" => [p[0], p[0], p[0]],
            2 => [p[0], p[1], 0.0],
            _ => [p[0], p[1], p[2]],
        }
    }

    /// The index of the alpha channel that RGBA formats write: the channel named `A` that
    /// [`Image::rgb`] does not already use.
    pub fn alpha_index(&self) -> Option<usize> {
        let a = self.channel_index("A")?;
        (a >= 3 || (self.channels == 2 && a == 1)).then_some(a)
    }

    /// One row's samples (width * channels floats).
    #[inline]
    pub fn row(&self, y: usize) -> &[f32] {
        let n = self.width * self.channels;
        &self.data[y * n..(y + 1) * n]
    }

    /// The same image with rows in reverse order.
    pub fn flipped_vertical(&self) -> Image {
        let mut out = self.clone();
        out.flip_vertical_in_place();
        out
    }

    /// Reverses the order of the rows, in place.
    pub fn flip_vertical_in_place(&mut self) {
        let n = self.width * self.channels;
        let h = self.height;
        for y in 0..h / 2 {
            let (top, bottom) = self.data.split_at_mut((h - 1 - y) * n);
            top[y * n..(y + 1) * n].swap_with_slice(&mut bottom[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flip_in_place_reverses_rows() {
        for h in [1, 2, 3, 4] {
            let img = Image::from_vec(2, h, 1, (0..2 * h).map(|v| v as f32).collect());
            let mut flipped = img.clone();
            flipped.flip_vertical_in_place();
            for y in 0..h {
                assert_eq!(flipped.row(y), img.row(h - 1 - y));
            }
        }
    }

    #[test]
    fn channels_split_by_name() {
        let img = Image::from_vec(1, 2, 4, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        assert_eq!(img.channel_index("A"), Some(3));
        let a = img.channel(3);
        assert_eq!(a.names, vec!["A"]);
        assert_eq!(a.data, vec![4.0, 8.0]);
    }
}
