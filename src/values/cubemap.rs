//! `Cubemap` (`cube map` in graphs): six square RGB f32 faces in the order +X, -X, +Y, -Y, +Z,
//! -Z (the OpenGL / KTX order; face axes in [`crate::geometry::cubemap`]), and `MipChain` (`mip
//! chain`): a list of cube maps, level k of size max(1, size >> k), with the perceptual roughness
//! each level was filtered for.
//!
//! Cache payloads: a cube map is its face size then its 18 S^2 f32 values; a chain is its level
//! count, then per level its roughness (f64) and its cube map. How `Save` writes them (strips of
//! the six faces, or KTX cube textures) is `crate::formats::save::cubemap`.

use glam::DVec3;

use super::image::Image;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};
use crate::geometry::cube_layout::CubeLayout;
use crate::geometry::cubemap as cube;

/// Six S x S RGB faces, face by face, row by row (row 0 at the top of each face), 3 floats per
/// texel: `data.len() == 6 * size * size * 3`.
/// The fields are public for the same reason as [`Image`]'s: operators fill and read the faces'
/// samples in place.
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

    /// Bilinear lookup at face point `(face, a, b)` (`a`, `b` in [-1, 1]), seamless: the texels
    /// past a face's edge are its neighbours' (`geometry::cubemap::seamless_texel_index`), so
    /// lookups are continuous across edges, even on 1 x 1 faces. In f64: the reference the
    /// vectorised prefilter kernel is tested against, and PlayCanvas' atlas rects.
    pub fn bilinear_at(&self, (face, a, b): (usize, f64, f64)) -> [f64; 3] {
        let s = self.size;
        let fx = (a + 1.0) * 0.5 * s as f64 - 0.5;
        let fy = (b + 1.0) * 0.5 * s as f64 - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let at = |x: i64, y: i64| self.texel(cube::seamless_texel_index(face, x, y, s)).map(f64::from);
        let (v00, v10, v01, v11) = (at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1));
        [0, 1, 2].map(|k| (v00[k] * (1.0 - tx) + v10[k] * tx) * (1.0 - ty) + (v01[k] * (1.0 - tx) + v11[k] * tx) * ty)
    }

    /// [`Cubemap::bilinear_at`] at direction `d`.
    pub fn bilinear(&self, d: DVec3) -> [f64; 3] {
        self.bilinear_at(cube::direction_to_face(d))
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
/// Plain data, its fields public: the GGX prefilter (`maths::brdf::ggx`) builds it level by level.
#[derive(Clone, Debug, PartialEq)]
pub struct MipChain {
    pub levels: Vec<Cubemap>,
    pub roughness: Vec<f64>,
}

pub static CUBEMAP: TypeSpec = TypeSpec {
    name: "cube map",
    doc: "six square RGB faces +X, -X, +Y, -Y, +Z, -Z (OpenGL/KTX order, hdrflow's axes); saved as a 6S x S strip or a .ktx2 cube",
    decode,
};

pub static MIP_CHAIN: TypeSpec = TypeSpec {
    name: "mip chain",
    doc: "cube maps, level k of face size max(1, size >> k), each with its roughness; saved one strip per level (`{level}` in the path), or as one .ktx2",
    decode: decode_chain,
};

/// The largest face size a cache entry may claim (2^14: 6 x 2^28 texels is above the engine's
/// image limit; this only bounds the arithmetic before the length is checked).
const MAX_SIZE: usize = 1 << 14;
/// The most levels a chain entry may claim.
const MAX_LEVELS: usize = 64;

impl ValueData for Cubemap {
    fn value_type(&self) -> ValueType {
        ValueType(&CUBEMAP)
    }
    fn approx_bytes(&self) -> usize {
        self.data.len() * 4
    }
    fn summary(&self) -> String {
        let n = self.texel_count().max(1) as f64;
        let mean: Vec<String> = (0..3)
            .map(|k| format!("{:.6}", self.data.iter().skip(k).step_by(3).map(|&v| v as f64).sum::<f64>() / n))
            .collect();
        format!("cube map {0}x{0} x 6, texel means R G B: {1}", self.size, mean.join(" "))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.size as u64);
        w.f32s(&self.data);
    }
}

fn read_cube(r: &mut Reader) -> Result<Cubemap, String> {
    let size = r.usize()?;
    if size == 0 || size > MAX_SIZE {
        return Err(format!("cube map face size {size} is out of range"));
    }
    let data = r.f32s()?;
    if data.len() != 18 * size * size {
        return Err("cube map size does not match its data".into());
    }
    Ok(Cubemap { size, data })
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let c = read_cube(&mut r)?;
    r.finish()?;
    Ok(Value::new(c))
}

impl ValueData for MipChain {
    fn value_type(&self) -> ValueType {
        ValueType(&MIP_CHAIN)
    }
    fn approx_bytes(&self) -> usize {
        self.levels.iter().map(|c| c.data.len() * 4).sum()
    }
    fn summary(&self) -> String {
        let sizes: Vec<String> = self.levels.iter().map(|c| c.size.to_string()).collect();
        format!("mip chain of {} cube maps, face sizes {}", self.levels.len(), sizes.join(" "))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        Writer(out).u64(self.levels.len() as u64);
        for (c, r) in self.levels.iter().zip(&self.roughness) {
            Writer(out).f64(*r);
            c.encode(out);
        }
    }
}

fn decode_chain(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let n = r.usize()?;
    if n > MAX_LEVELS {
        return Err(format!("{n} mip levels is out of range"));
    }
    let mut chain = MipChain { levels: Vec::with_capacity(n), roughness: Vec::with_capacity(n) };
    for _ in 0..n {
        chain.roughness.push(r.f64()?);
        chain.levels.push(read_cube(&mut r)?);
    }
    r.finish()?;
    Ok(Value::new(chain))
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

    #[test]
    fn round_trips_and_strip_layout() {
        let mut c = Cubemap::new(2);
        for (i, v) in c.data.iter_mut().enumerate() {
            *v = i as f32;
        }
        let mut bytes = Vec::new();
        c.encode(&mut bytes);
        assert_eq!(decode(&bytes).unwrap().get::<Cubemap>(), Some(&c));
        for cut in [0, 8, bytes.len() - 1] {
            let e = decode(&bytes[..cut]).unwrap_err();
            assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
        }
        let chain = MipChain { levels: vec![c.clone(), Cubemap::new(1)], roughness: vec![0.0, 1.0] };
        let mut bytes = Vec::new();
        chain.encode(&mut bytes);
        assert_eq!(decode_chain(&bytes).unwrap().get::<MipChain>(), Some(&chain));
        let e = decode_chain(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.starts_with("truncated: need"), "{e}");
        // The strip: face f at columns f*S..(f+1)*S, and back.
        let strip = c.to_strip();
        assert_eq!((strip.width, strip.height), (12, 2));
        assert_eq!(strip.rgb(2, 0), c.texel(4));
        assert_eq!(Cubemap::from_strip(&strip), Some(c));
    }
}
