//! `Cubemap`: six square RGB f32 faces in the order +X, -X, +Y, -Y, +Z, -Z (the OpenGL / KTX
//! order; face axes in [`crate::geometry::cubemap`]), and `MipChain`: a list of cube maps, level
//! k of size max(1, size >> k), with the perceptual roughness each level was filtered for.

use crate::data::Image;
use crate::geometry::cube_layout::CubeLayout;
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
        self.to_layout(CubeLayout::Strip)
    }

    /// The cube map of a 6S x S strip (the inverse of `to_strip`); `None` unless the image is
    /// six squares wide with at least 3 channels (RGB first) or one (grey).
    pub fn from_strip(img: &Image) -> Option<Cubemap> {
        Cubemap::from_layout(img, CubeLayout::Strip).ok()
    }

    /// The cube map as one RGB image of `layout` (`geometry::cube_layout`): each face copied
    /// into its cell, turned as the layout says; cells without a face are 0.
    pub fn to_layout(&self, layout: CubeLayout) -> Image {
        let s = self.size;
        let (w, h) = layout.image_size(s);
        let mut out = Image::new(w, h, 3);
        for (f, c) in layout.cells().iter().enumerate() {
            for j in 0..s {
                for i in 0..s {
                    let (x, y) = c.turn.apply(i, j, s);
                    out.pixel_mut(c.col * s + i, c.row * s + j).copy_from_slice(&self.texel((f * s + y) * s + x));
                }
            }
        }
        out
    }

    /// The cube map held by an image of `layout`, the inverse of `to_layout` (cells without a
    /// face are not read); RGB is the first three channels, one channel is grey, a second
    /// channel (alpha) is ignored. An error says why the image's size is not the layout's.
    pub fn from_layout(img: &Image, layout: CubeLayout) -> Result<Cubemap, String> {
        let s = layout.face_size(img.width, img.height)?;
        let cells = layout.cells();
        Ok(Cubemap::from_fn(s, |f, x, y| {
            let c = cells[f];
            let (i, j) = c.turn.apply(x, y, s);
            img.rgb(c.col * s + i, c.row * s + j)
        }))
    }

    /// Face `face` (storage index, 0 = +X) as an S x S RGB image, as stored (its axes in
    /// `geometry::cubemap`).
    pub fn face_image(&self, face: usize) -> Image {
        let (s, n) = (self.size, 3 * self.size * self.size);
        Image::from_vec(s, s, 3, self.data[face * n..(face + 1) * n].to_vec())
    }

    /// The cube map of six face images in storage order (+X, -X, +Y, -Y, +Z, -Z), each as
    /// stored (RGB, or grey); an error names the first face that is not square or not of the
    /// first face's size.
    pub fn from_faces(faces: [&Image; 6]) -> Result<Cubemap, String> {
        let s = faces[0].width;
        for (f, img) in faces.iter().enumerate() {
            let name = cube::FACE_NAMES[f];
            if img.width != img.height || img.width == 0 {
                return Err(format!("face {name} is {} x {}: a face must be square", img.width, img.height));
            }
            if img.width != s {
                return Err(format!(
                    "face {name} is {0} x {0} but face +X is {s} x {s}: the faces must be the same size",
                    img.width
                ));
            }
        }
        Ok(Cubemap::from_fn(s, |f, x, y| faces[f].rgb(x, y)))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn numbered(size: usize) -> Cubemap {
        let mut c = Cubemap::new(size);
        for (i, v) in c.data.iter_mut().enumerate() {
            *v = i as f32 + 1.0;
        }
        c
    }

    #[test]
    fn layouts_round_trip_exactly_and_leave_unused_cells_black() {
        let c = numbered(3);
        for layout in CubeLayout::ALL {
            let img = c.to_layout(layout);
            assert_eq!((img.width, img.height), layout.image_size(3));
            assert_eq!(Cubemap::from_layout(&img, layout).as_ref(), Ok(&c), "{layout}");
            // Every texel once (all values differ), and 0 elsewhere.
            let used = img.data.iter().filter(|&&v| v != 0.0).count();
            assert_eq!(used, c.data.len(), "{layout}");
            let (cols, rows) = layout.grid();
            for (col, row) in (0..rows).flat_map(|r| (0..cols).map(move |q| (q, r))) {
                if layout.face_at(col, row).is_none() {
                    assert!((0..3).all(|j| (0..3).all(|i| img.pixel(col * 3 + i, row * 3 + j) == [0.0; 3])));
                }
            }
        }
        assert_eq!(c.to_strip(), c.to_layout(CubeLayout::Strip));
        let e = Cubemap::from_layout(&Image::new(10, 3, 3), CubeLayout::Dice).unwrap_err();
        assert!(e.starts_with("a Dice image is 4 faces wide and 3 high") && e.ends_with("this one is 10 x 3"), "{e}");
    }

    #[test]
    fn faces_round_trip_and_grey_or_rgba_inputs_read_as_rgb() {
        let c = numbered(2);
        let faces: Vec<Image> = (0..6).map(|f| c.face_image(f)).collect();
        let refs = [&faces[0], &faces[1], &faces[2], &faces[3], &faces[4], &faces[5]];
        assert_eq!(Cubemap::from_faces(refs), Ok(c.clone()));
        let grey = Image::from_vec(2, 2, 1, vec![1.0, 2.0, 3.0, 4.0]);
        let rgba = Image::from_vec(2, 2, 4, (0..16).map(|v| v as f32).collect());
        let g = Cubemap::from_faces([&grey, &rgba, &grey, &grey, &grey, &grey]).unwrap();
        assert_eq!((g.texel(3), g.texel(4 + 1)), ([4.0; 3], [4.0, 5.0, 6.0]));
        let tall = Image::new(2, 3, 3);
        let e = Cubemap::from_faces([&faces[0], &faces[1], &tall, &faces[3], &faces[4], &faces[5]]).unwrap_err();
        assert!(e.contains("face +Y is 2 x 3"), "{e}");
        let big = Image::new(3, 3, 3);
        let e = Cubemap::from_faces([&faces[0], &faces[1], &faces[2], &faces[3], &faces[4], &big]).unwrap_err();
        assert!(e.contains("face -Z is 3 x 3 but face +X is 2 x 2"), "{e}");
    }
}
