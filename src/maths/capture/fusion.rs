//! Exposure fusion (Mertens, Kautz and Van Reeth, "Exposure Fusion", Pacific Graphics 2007), as
//! OpenCV's `MergeMertens` computes it with its default exponents (1, 1, 1): the picture
//! photographers preview, display-referred, with no response and no exposure times.
//!
//! Each frame's values are its codes over `max` (display values in [0, 1], not linearised).
//! Weights per pixel: contrast `C = |laplacian(grey)|` (the 3 x 3 kernel `0 1 0 / 1 -4 1 /
//! 0 1 0`, grey = `0.299 R + 0.587 G + 0.114 B`), saturation `S = sqrt(sum_c (v_c - mean)^2)`
//! (OpenCV's, not divided by 3), well-exposedness `X = prod_c exp(-(v_c - 0.5)^2 / 0.08)`
//! (sigma 0.2); `W = C S X + 1e-12`, normalised over the frames. The result is the sum over
//! frames of each frame's Laplacian pyramid times its weight's Gaussian pyramid, collapsed;
//! `floor(log2(min(width, height)))` levels, the 5-tap binomial `1 4 6 4 1 / 16` of
//! `pyrDown`/`pyrUp` (edges repeated where OpenCV reflects: the borders may differ slightly).
//! The blend can over- or undershoot [0, 1] a little near strong edges; unlike OpenCV we clamp
//! to [0, 1], the range of a display-referred picture.

use rayon::prelude::*;

use crate::values::brackets::Brackets;

/// An interleaved float plane of `c` channels.
#[derive(Clone)]
struct Plane {
    w: usize,
    h: usize,
    c: usize,
    d: Vec<f32>,
}

impl Plane {
    fn at(&self, x: isize, y: isize, k: usize) -> f32 {
        let x = x.clamp(0, self.w as isize - 1) as usize;
        let y = y.clamp(0, self.h as isize - 1) as usize;
        self.d[(y * self.w + x) * self.c + k]
    }
}

const K: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

/// Blur with the binomial kernel and keep every other pixel: `((w + 1) / 2) x ((h + 1) / 2)`.
fn down(p: &Plane) -> Plane {
    let (w, h) = (p.w.div_ceil(2), p.h.div_ceil(2));
    let mut d = vec![0f32; w * h * p.c];
    d.par_chunks_mut(w * p.c).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            for k in 0..p.c {
                let mut s = 0.0;
                for (j, ky) in K.iter().enumerate() {
                    for (i, kx) in K.iter().enumerate() {
                        s += ky * kx * p.at(2 * x as isize + i as isize - 2, 2 * y as isize + j as isize - 2, k);
                    }
                }
                row[x * p.c + k] = s;
            }
        }
    });
    Plane { w, h, c: p.c, d }
}

/// Upsample to `w x h`: zeros between the samples, blurred with four times the kernel.
fn up(p: &Plane, w: usize, h: usize) -> Plane {
    // Per dimension: even outputs (s[i-1] + 6 s[i] + s[i+1]) / 8, odd ones (s[i] + s[i+1]) / 2.
    let taps = |o: usize| -> [(isize, f32); 3] {
        let i = (o / 2) as isize;
        if o.is_multiple_of(2) {
            [(i - 1, 0.125), (i, 0.75), (i + 1, 0.125)]
        } else {
            [(i, 0.5), (i + 1, 0.5), (i, 0.0)]
        }
    };
    let mut d = vec![0f32; w * h * p.c];
    d.par_chunks_mut(w * p.c).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            for k in 0..p.c {
                let mut s = 0.0;
                for (sy, wy) in taps(y) {
                    for (sx, wx) in taps(x) {
                        s += wy * wx * p.at(sx, sy, k);
                    }
                }
                row[x * p.c + k] = s;
            }
        }
    });
    Plane { w, h, c: p.c, d }
}

fn gaussian_pyramid(p: Plane, levels: usize) -> Vec<Plane> {
    let mut pyr = vec![p];
    for _ in 0..levels {
        let next = down(pyr.last().expect("one level"));
        pyr.push(next);
    }
    pyr
}

/// The fused picture, row-major RGB in [0, 1] (see the module documentation).
pub fn fuse(b: &Brackets) -> Vec<f32> {
    let (w, h) = (b.width, b.height);
    let max = b.max_code() as f32;
    let frame = |f: usize| Plane {
        w,
        h,
        c: 3,
        d: (0..w * h * 3).into_par_iter().map(|i| b.frames[f].codes.get(i) as f32 / max).collect(),
    };
    // Weights, then their normalisation over the frames.
    let mut weights: Vec<Vec<f32>> = (0..b.frames.len()).map(|f| weight_map(&frame(f))).collect();
    let sum: Vec<f32> = (0..w * h).into_par_iter().map(|i| weights.iter().map(|wf| wf[i]).sum()).collect();
    for wf in &mut weights {
        wf.par_iter_mut().zip(&sum).for_each(|(v, s)| *v /= s);
    }
    let levels = (w.min(h).max(1) as f64).log2().floor() as usize;
    let mut acc: Option<Vec<Plane>> = None;
    for (f, wf) in weights.into_iter().enumerate() {
        let wp = gaussian_pyramid(Plane { w, h, c: 1, d: wf }, levels);
        let gp = gaussian_pyramid(frame(f), levels);
        // Laplacian level l = G_l - up(G_{l+1}); the top level is G_top.
        let lap: Vec<Plane> = (0..=levels)
            .map(|l| {
                let mut g = gp[l].clone();
                if l < levels {
                    let u = up(&gp[l + 1], g.w, g.h);
                    g.d.iter_mut().zip(&u.d).for_each(|(a, b)| *a -= b);
                }
                g.d.par_chunks_mut(3).zip(&wp[l].d).for_each(|(px, wv)| px.iter_mut().for_each(|v| *v *= wv));
                g
            })
            .collect();
        acc = Some(match acc {
            None => lap,
            Some(mut a) => {
                for (al, ll) in a.iter_mut().zip(&lap) {
                    al.d.iter_mut().zip(&ll.d).for_each(|(x, y)| *x += y);
                }
                a
            }
        });
    }
    let mut pyr = acc.expect("at least one frame");
    for l in (0..levels).rev() {
        let u = up(&pyr[l + 1], pyr[l].w, pyr[l].h);
        pyr[l].d.iter_mut().zip(&u.d).for_each(|(a, b)| *a += b);
    }
    let mut out = std::mem::take(&mut pyr[0].d);
    out.iter_mut().for_each(|v| *v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 });
    out
}

/// `C S X + 1e-12` per pixel of one frame.
fn weight_map(p: &Plane) -> Vec<f32> {
    let grey = |x: isize, y: isize| 0.299 * p.at(x, y, 0) + 0.587 * p.at(x, y, 1) + 0.114 * p.at(x, y, 2);
    (0..p.w * p.h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % p.w) as isize, (i / p.w) as isize);
            let lap = grey(x - 1, y) + grey(x + 1, y) + grey(x, y - 1) + grey(x, y + 1) - 4.0 * grey(x, y);
            let v = &p.d[i * 3..i * 3 + 3];
            let mean = (v[0] + v[1] + v[2]) / 3.0;
            let sat = v.iter().map(|c| (c - mean) * (c - mean)).sum::<f32>().sqrt();
            let expo: f32 = v.iter().map(|c| (-(c - 0.5) * (c - 0.5) / 0.08).exp()).product();
            lap.abs() * sat * expo + 1e-12
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::brackets::{Codes, Frame};

    fn bracket(codes: Vec<Vec<u8>>, w: usize, h: usize) -> Brackets {
        let frames = codes
            .into_iter()
            .enumerate()
            .map(|(i, c)| Frame { name: format!("f{i}"), time: 1.0 + i as f64, codes: Codes::U8(c), covered: None })
            .collect();
        Brackets::new(w, h, 8, frames).unwrap()
    }

    #[test]
    fn identical_frames_fuse_to_themselves_and_flat_ones_stay_flat() {
        let (w, h) = (23, 17);
        let img: Vec<u8> = (0..w * h * 3).map(|i| ((i * 37) % 200 + 20) as u8).collect();
        let out = fuse(&bracket(vec![img.clone(), img.clone()], w, h));
        for (o, c) in out.iter().zip(&img) {
            assert!((o - *c as f32 / 255.0).abs() < 1e-4, "{o} vs {c}");
        }
        // Two flat frames (no contrast: equal weights): the fused value lies between them.
        let out = fuse(&bracket(vec![vec![40; w * h * 3], vec![120; w * h * 3]], w, h));
        assert!(out.iter().all(|v| *v > 40.0 / 255.0 && *v < 120.0 / 255.0 && v.is_finite()));
        let black_white = fuse(&bracket(vec![vec![0; w * h * 3], vec![255; w * h * 3]], w, h));
        assert!(black_white.iter().all(|v| (0.0..=1.0).contains(v)));
    }
}
