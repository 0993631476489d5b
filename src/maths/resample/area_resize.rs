//! Area-averaging resampling (a box filter with exact fractional coverage), energy-preserving:
//! every output pixel is the mean of the input area it covers, so the image mean (and the
//! integral of a lat-long map over the sphere, up to the sin(theta) weighting within a row band)
//! is unchanged, for shrinking and enlarging alike.
//!
//! Separable: output column j covers input columns [j*W/w, (j+1)*W/w); each input column
//! contributes the length of its overlap, divided by W/w.
//!
//! Every channel is averaged alike, alpha included, and the channel names are kept: for
//! premultiplied alpha (OpenEXR's convention) that is exact compositing coverage; an opaque
//! image (A = 1) stays opaque.

use rayon::prelude::*;

use crate::values::Image;

/// For each output index, the (input index, weight) pairs; weights sum to 1.
fn box_weights(src: usize, dst: usize) -> Vec<Vec<(usize, f64)>> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|j| {
            let (a, b) = (j as f64 * scale, (j + 1) as f64 * scale);
            let first = a.floor() as usize;
            let last = ((b.ceil() as usize).max(first + 1)).min(src);
            (first..last)
                .filter_map(|i| {
                    let overlap = (b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0);
                    (overlap > 0.0).then_some((i, overlap / scale))
                })
                .collect()
        })
        .collect()
}

/// Resizes `img` to `w` x `h` by area averaging (f64 accumulation), keeping its channel names.
pub fn resize(img: &Image, w: usize, h: usize) -> Image {
    let c = img.channels;
    let wx = box_weights(img.width, w);
    let wy = box_weights(img.height, h);
    // Horizontal pass: height x w.
    let mut tmp = vec![0.0f64; img.height * w * c];
    tmp.par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        let src = img.row(y);
        for (j, taps) in wx.iter().enumerate() {
            for &(i, wgt) in taps {
                for k in 0..c {
                    row[j * c + k] += wgt * src[i * c + k] as f64;
                }
            }
        }
    });
    // Vertical pass.
    let mut out = vec![0.0f32; w * h * c];
    out.par_chunks_mut(w * c).enumerate().for_each(|(j, row)| {
        let mut acc = vec![0.0f64; w * c];
        for &(i, wgt) in &wy[j] {
            for (a, &t) in acc.iter_mut().zip(&tmp[i * w * c..(i + 1) * w * c]) {
                *a += wgt * t;
            }
        }
        for (o, a) in row.iter_mut().zip(acc) {
            *o = a as f32;
        }
    });
    Image::with_names(w, h, img.names.clone(), out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean(img: &Image) -> f64 {
        img.data.iter().map(|&v| v as f64).sum::<f64>() / img.data.len() as f64
    }

    #[test]
    fn preserves_mean_when_shrinking_and_enlarging() {
        let img = Image::from_vec(7, 5, 1, (0..35).map(|i| (i * i % 11) as f32).collect());
        for (w, h) in [(3, 2), (14, 10), (1, 1), (7, 5), (5, 7)] {
            let r = resize(&img, w, h);
            assert!((mean(&r) - mean(&img)).abs() < 1e-5, "{w}x{h}");
        }
    }

    #[test]
    fn rgba_keeps_its_names_and_an_opaque_alpha() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let data = (0..5 * 3).flat_map(|i| [i as f32, 1.0, 2.0, 1.0]).collect();
        let img = Image::with_names(5, 3, names.clone(), data);
        let out = resize(&img, 2, 2);
        assert_eq!(out.names, names);
        assert!(out.data.chunks_exact(4).all(|p| (p[3] - 1.0).abs() < 1e-6 && (p[1] - 1.0).abs() < 1e-6));
    }

    #[test]
    fn halving_averages_2x2_blocks() {
        let img = Image::from_vec(2, 2, 1, vec![1.0, 2.0, 3.0, 6.0]);
        assert_eq!(resize(&img, 1, 1).data, vec![3.0]);
    }
}
