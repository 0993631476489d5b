//! Small tone-mapped PNGs of a run's image outputs, for the HTML report.
//!
//! HDR files (`.exr`, `.hdr`, `.pfm`) are decoded by hdrflow's own readers, shrunk with the
//! `image` crate's area filter, exposed so that their mean luminance is 0.18 and tone-mapped with
//! extended Reinhard, `L' = L (1 + L / W^2) / (1 + L)` per channel with white point `W = 4`
//! (Reinhard et al. 2002, eq. 4), then sRGB-encoded. PNG files (already display-referred) are
//! only shrunk.

use std::path::Path;

use crate::formats;
use crate::values::Image;

/// Longest side of a thumbnail, in pixels.
pub const MAX_SIDE: u32 = 320;

/// White point of the extended Reinhard curve (in units of the exposed luminance).
const WHITE: f32 = 4.0;

/// A PNG thumbnail of the image file at `path`, or `None` if it is not an image hdrflow reads
/// (or cannot be read now).
pub fn of_file(path: &Path) -> Option<Vec<u8>> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    let bytes = std::fs::read(path).ok()?;
    match ext.as_str() {
        "png" => {
            let img = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png).ok()?;
            encode_png(&img.thumbnail(MAX_SIDE, MAX_SIDE))
        }
        e if formats::SUPPORTED_EXTENSIONS.contains(&e) => {
            let img = formats::decode_by_extension(&bytes, e).ok()?;
            of_hdr(&img)
        }
        _ => None,
    }
}

/// A tone-mapped PNG thumbnail of a linear image (1, 3 or 4 channels; others use their first).
pub fn of_hdr(img: &Image) -> Option<Vec<u8>> {
    if img.width == 0 || img.height == 0 || img.channels == 0 {
        return None;
    }
    let rgb = image::Rgb32FImage::from_fn(u32::try_from(img.width).ok()?, u32::try_from(img.height).ok()?, |x, y| {
        let px = img.pixel(x as usize, y as usize);
        let v = |k: usize| {
            let s = px[k.min(px.len() - 1)];
            if s.is_finite() {
                s.max(0.0)
            } else {
                0.0
            }
        };
        if img.channels >= 3 {
            image::Rgb([v(0), v(1), v(2)])
        } else {
            image::Rgb([v(0), v(0), v(0)])
        }
    });
    let (w, h) = fit(rgb.width(), rgb.height());
    let small = image::imageops::thumbnail(&rgb, w, h);
    let mean: f64 = small.pixels().map(|p| luminance(p.0) as f64).sum::<f64>() / (small.len() / 3).max(1) as f64;
    let gain = if mean > 0.0 { (0.18 / mean) as f32 } else { 1.0 };
    let out = image::RgbImage::from_fn(small.width(), small.height(), |x, y| {
        let p = small.get_pixel(x, y).0;
        image::Rgb(p.map(|c| {
            let l = c * gain;
            let mapped = l * (1.0 + l / (WHITE * WHITE)) / (1.0 + l);
            formats::srgb8::linear_to_srgb8(mapped as f64)
        }))
    });
    encode_png(&image::DynamicImage::ImageRgb8(out))
}

/// The size that fits `w x h` in `MAX_SIDE` keeping the aspect (at least one pixel a side).
fn fit(w: u32, h: u32) -> (u32, u32) {
    if w <= MAX_SIDE && h <= MAX_SIDE {
        return (w, h);
    }
    let s = MAX_SIDE as f64 / w.max(h) as f64;
    (((w as f64 * s).round() as u32).max(1), ((h as f64 * s).round() as u32).max(1))
}

fn luminance(rgb: [f32; 3]) -> f32 {
    let [wr, wg, wb] = crate::colour::REC709_F32;
    wr * rgb[0] + wg * rgb[1] + wb * rgb[2]
}

fn encode_png(img: &image::DynamicImage) -> Option<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).ok()?;
    Some(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_hdr_image_becomes_a_small_png_of_the_same_aspect() {
        let img = Image::from_fn_rgb(1024, 512, |x, _| [x as f32 * 10.0, 1.0, f32::NAN]);
        let png = of_hdr(&img).expect("a thumbnail");
        let back = image::load_from_memory(&png).unwrap();
        assert_eq!((back.width(), back.height()), (320, 160));
    }

    #[test]
    fn fitting_keeps_small_images_and_the_aspect_of_large_ones() {
        assert_eq!(fit(64, 32), (64, 32));
        assert_eq!(fit(8192, 4096), (320, 160));
        assert_eq!(fit(10000, 1), (320, 1));
    }
}
