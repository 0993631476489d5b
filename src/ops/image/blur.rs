//! `Blur(image, sigma, wrap: false)`: separable Gaussian blur.
//!
//! out(x, y) = sum_{i, j = -r..r} w_i w_j image(X(x + i), Y(y + j)), with
//!
//! ```text
//! r   = ceil(3 sigma)                                   (the kernel's radius, in pixels)
//! w_i = exp(-i^2 / (2 sigma^2)) / sum_{k=-r..r} exp(-k^2 / (2 sigma^2))
//! ```
//!
//! the sampled Gaussian, normalised so that the weights sum to 1 (a constant image stays
//! constant). The 3-sigma cut drops 0.27% of the continuous Gaussian's mass; normalising puts
//! it back on the taps. `sigma: 0` is the identity (the input is passed on untouched).
//!
//! **Edges.** Rows: clamp to the edge, Y(y) = clamp(y, 0, H - 1). Columns: clamp to the edge
//! too, or with `wrap: true` wrap around, X(x) = x mod W, which is what a lat-long map needs
//! (its column W - 1 neighbours column 0 across the seam at phi = 0). With `wrap: true` the
//! horizontal pass moves no energy out of a row, so every row's mean, and the mean of an image
//! one row high, is unchanged up to rounding; clamping at the top and bottom rows (the poles)
//! does weight the edge rows more, so the whole image's mean may change there.
//!
//! **Numerics.** Horizontal pass then vertical pass, each sample a sum in f64 of f32 inputs,
//! rounded to f32 once per pass. Each pass runs in parallel over rows (rayon). Every channel
//! is blurred alike, alpha included, which is right for premultiplied alpha (OpenEXR's
//! convention). NaN and Inf spread to every pixel within r.

use rayon::prelude::*;

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct BlurParams {
        /// the image to blur
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// standard deviation of the Gaussian, in pixels (0: no blur; the kernel radius is ceil(3 sigma))
        #[range(0.0, 1000.0)]
        pub sigma: f64,
        /// wrap around horizontally (lat-long maps); false clamps to the edge
        pub wrap: bool = false,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Blur", 1, "Separable Gaussian blur (radius 3 sigma), clamp or horizontal wrap-around", eval)
        .output_like("image", |p| p.image, "the blurred image")
        .size(|_, p| p.image.size)
        .into()
}

/// The normalised kernel `w_{-r..r}` (length 2r + 1, r = ceil(3 sigma)); `[1.0]` for sigma 0.
pub fn kernel(sigma: f64) -> Vec<f64> {
    if !(sigma > 0.0) {
        return vec![1.0];
    }
    let r = (3.0 * sigma).ceil() as i64;
    let w: Vec<f64> = (-r..=r).map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|v| v / sum).collect()
}

/// The horizontal pass: each row convolved with `k`, clamped or wrapped at its ends.
fn horizontal(img: &Image, k: &[f64], wrap: bool) -> Vec<f32> {
    let (w, c) = (img.width, img.channels);
    let r = (k.len() - 1) / 2;
    let mut out = vec![0f32; img.data.len()];
    out.par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        let src = img.row(y);
        // The row with r pixels added at each end, so that the taps need no index arithmetic.
        let mut padded = Vec::with_capacity((w + 2 * r) * c);
        for i in 0..w + 2 * r {
            let sx = i as i64 - r as i64;
            let x = if wrap { sx.rem_euclid(w as i64) } else { sx.clamp(0, w as i64 - 1) } as usize;
            padded.extend_from_slice(&src[x * c..(x + 1) * c]);
        }
        let mut acc = vec![0f64; c];
        for (x, px) in row.chunks_exact_mut(c).enumerate() {
            acc.fill(0.0);
            for (t, &wt) in k.iter().enumerate() {
                for (a, &v) in acc.iter_mut().zip(&padded[(x + t) * c..(x + t + 1) * c]) {
                    *a += wt * v as f64;
                }
            }
            for (o, a) in px.iter_mut().zip(&acc) {
                *o = *a as f32;
            }
        }
    });
    out
}

/// The vertical pass over `data` (rows of `w * c` samples), clamped at the top and bottom.
fn vertical(data: &[f32], w: usize, h: usize, c: usize, k: &[f64]) -> Vec<f32> {
    let n = w * c;
    let r = (k.len() - 1) / 2;
    let mut out = vec![0f32; data.len()];
    out.par_chunks_mut(n).enumerate().for_each(|(y, row)| {
        let mut acc = vec![0f64; n];
        for (t, &wt) in k.iter().enumerate() {
            let sy = (y as i64 + t as i64 - r as i64).clamp(0, h as i64 - 1) as usize;
            for (a, &v) in acc.iter_mut().zip(&data[sy * n..(sy + 1) * n]) {
                *a += wt * v as f64;
            }
        }
        for (o, a) in row.iter_mut().zip(acc) {
            *o = a as f32;
        }
    });
    out
}

/// The blurred image (same size, channels and names).
pub fn blur(img: &Image, sigma: f64, wrap: bool) -> Image {
    let k = kernel(sigma);
    if k.len() == 1 || img.data.is_empty() {
        return img.clone();
    }
    let tmp = horizontal(img, &k, wrap);
    let data = vertical(&tmp, img.width, img.height, img.channels, &k);
    Image::with_names(img.width, img.height, img.names.clone(), data)
}

fn eval(_: &mut OpContext, p: BlurParams) -> Result<Value, OpError> {
    if p.sigma == 0.0 {
        return Ok(p.image.into_value());
    }
    Ok(Value::new(blur(&p.image, p.sigma, p.wrap)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(w: usize, h: usize, c: usize) -> Image {
        let mut s = 0x9e3779b97f4a7c15u64;
        let data = (0..w * h * c)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 40) as f32 / (1u64 << 24) as f32 * 100.0
            })
            .collect();
        Image::from_vec(w, h, c, data)
    }

    fn mean(data: &[f32]) -> f64 {
        data.iter().map(|&v| v as f64).sum::<f64>() / data.len() as f64
    }

    #[test]
    fn kernel_is_the_normalised_sampled_gaussian() {
        let k = kernel(2.0);
        assert_eq!(k.len(), 2 * 6 + 1);
        assert!((k.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        // w_i / w_0 = exp(-i^2 / (2 sigma^2)).
        assert!((k[6 + 3] / k[6] - (-9.0f64 / 8.0).exp()).abs() < 1e-15);
        assert_eq!(kernel(0.0), vec![1.0]);
        assert_eq!(kernel(0.3).len(), 3); // r = ceil(0.9) = 1
    }

    #[test]
    fn a_delta_blurs_to_the_sampled_gaussian() {
        let (n, c0, sigma) = (31, 15, 2.5);
        let mut img = Image::new(n, n, 1);
        img.data[c0 * n + c0] = 1.0;
        let k = kernel(sigma);
        let r = (k.len() - 1) / 2;
        for wrap in [false, true] {
            let out = blur(&img, sigma, wrap);
            for y in 0..n {
                for x in 0..n {
                    let (dx, dy) = (x as i64 - c0 as i64, y as i64 - c0 as i64);
                    let want = if dx.unsigned_abs() as usize <= r && dy.unsigned_abs() as usize <= r {
                        k[(dx + r as i64) as usize] * k[(dy + r as i64) as usize]
                    } else {
                        0.0
                    };
                    let got = out.data[y * n + x] as f64;
                    assert!((got - want).abs() <= 2.5e-7 * want, "({x}, {y}): {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn wrap_preserves_row_means_and_a_constant_stays_constant() {
        let img = noise(37, 4, 3);
        let k = kernel(3.0);
        let tmp = horizontal(&img, &k, true);
        let n = 37 * 3;
        for y in 0..4 {
            let (before, after) = (mean(&img.data[y * n..(y + 1) * n]), mean(&tmp[y * n..(y + 1) * n]));
            assert!((after - before).abs() <= 1e-6 * before, "row {y}: {before} -> {after}");
        }
        // One row: the vertical pass is the identity, so the image's mean is preserved.
        let row = noise(64, 1, 1);
        let out = blur(&row, 5.0, true);
        assert!((mean(&out.data) - mean(&row.data)).abs() <= 1e-6 * mean(&row.data));
        // A wide kernel (radius 30) on a 64-pixel row wraps several times and still keeps it.
        let out = blur(&row, 10.0, true);
        assert!((mean(&out.data) - mean(&row.data)).abs() <= 1e-6 * mean(&row.data));
        let flat = Image::from_vec(9, 7, 2, vec![0.3; 9 * 7 * 2]);
        for wrap in [false, true] {
            assert!(blur(&flat, 4.0, wrap).data.iter().all(|&v| (v - 0.3).abs() <= 1e-7));
        }
    }

    #[test]
    fn wrap_and_clamp_differ_at_the_seam() {
        // A bright column 0: wrapped, it bleeds into column W - 1; clamped, column W - 1 stays
        // dark and column 0 keeps more of its light (its left taps all read column 0).
        let (w, h) = (16, 3);
        let mut img = Image::new(w, h, 1);
        for y in 0..h {
            img.data[y * w] = 1.0;
        }
        let (wrapped, clamped) = (blur(&img, 1.5, true), blur(&img, 1.5, false));
        let k = kernel(1.5);
        let r = (k.len() - 1) / 2;
        assert!((wrapped.data[w - 1] as f64 - k[r + 1]).abs() < 1e-7);
        assert_eq!(clamped.data[w - 1], 0.0);
        let left: f64 = k[..=r].iter().sum();
        assert!((clamped.data[0] as f64 - left).abs() < 1e-7);
        assert!((wrapped.data[0] as f64 - k[r]).abs() < 1e-7);
    }

    #[test]
    fn sigma_zero_is_the_identity_and_names_are_kept() {
        let names: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
        let img = Image::with_names(3, 2, names.clone(), (0..24).map(|v| v as f32).collect());
        assert_eq!(blur(&img, 0.0, false), img);
        assert_eq!(blur(&img, 1.0, true).names, names);
    }
}
