//! Merging bracketed exposures into relative radiance.
//!
//! Per pixel and channel, over the frames `i` (exposure time `t_i`, code `z_i`), with the
//! response `x(z)` (relative exposure of a code, [`Response`]) and a weight `w_i(z)`:
//!
//! `E = sum_i w_i(z_i) x(z_i) / t_i  /  sum_i w_i(z_i)`
//!
//! the weighted mean of the frames' radiance estimates in the linear domain. Debevec and Malik
//! (1997, eq. 6) and OpenCV's `MergeDebevec` average `g(z) - ln t` in the log domain instead,
//! i.e. a weighted geometric mean; we average linearly because the frames' noise is additive
//! in the linear domain (shot, read, quantisation), where the mean of unbiased estimates is
//! unbiased, whereas the mean of logs is biased low by about half the relative variance
//! (Jensen), most at the dark codes; and because a code standing for 0 (x(0) = 0 for a true
//! sRGB response) has no logarithm. Weights `w_i(z)`:
//! - `Hat`: Debevec and Malik's triangle, `min(z, max - z) / (max / 2)` (0 at both ends);
//! - `Gaussian`: Robertson et al.'s (2003) weight as OpenCV's `RobertsonWeights`,
//!   `(e^4 exp(-(4 z / max - 2)^2) - 1) / (e^4 - 1)` (0 at both ends, 1 in the middle);
//! - `NoiseOptimal`: `t_i / t_max` for `0 < z < max`, else 0: inverse-variance weights under
//!   shot noise (the variance of `x / t` is `E / t`), which make the merge
//!   `sum_i x(z_i) / sum_i t_i` over the unclipped frames, the maximum-likelihood radiance of
//!   a Poisson sensor (Hasinoff, Durand and Freeman 2010, without read noise).
//!
//! A frame whose `covered` mask is 0 at the pixel has weight 0. When the weights of a channel
//! sum to 0 (every usable code at an end): if the code is at the top (`max`) in every frame,
//! the pixel is saturated, takes the shortest exposure's value `x(max) / t_min` (a lower bound)
//! and is marked in the `saturated` mask; otherwise it takes the longest frame's below the top,
//! `x(z) / t` (for a pixel dark everywhere, the longest exposure's `x(0) / t_max`, and the
//! pixel counts as underexposed). If no frame covers the pixel, every frame counts. So no
//! output is NaN or infinite: each is a finite weighted mean or one finite table entry.
//! `confidence` is the mean over the channels of `sum_i w_i`.
//!
//! `Consistency` deghosting (a simplified Granados et al. 2013 consistency test): the
//! reference is the frame nearest the middle exposure (index `(n - 1) / 2`) whose weight is
//! positive in every channel; another frame is dropped at that pixel when, in a channel where
//! both weights are positive, `|E_i - E_ref| > 3 (q_i + q_ref) + 0.1 max(E_i, E_ref)`: `q` half
//! the response's step at the code divided by `t` (the quantisation error bound), and 10% for
//! the sensor noise of a mid-grey code. A static pixel of a noise-free capture with the right
//! response is never dropped (its frames differ by at most `q_i + q_ref`). With two frames
//! there is no majority to side with, and nothing is dropped.
//!
//! Speed: per frame and channel a table `code -> (w, x / t)` (and `q` when deghosting), so the
//! inner loop reads one code and one table entry per frame; rows run in parallel; no float
//! copy of a frame is made (the peak is the frames, the tables and the outputs).

use rayon::prelude::*;

use super::response::{max_code, Response};
use crate::values::brackets::{Brackets, Codes};

crate::choice! {
    /// The weight of a code in the merge (see the module documentation).
    pub enum Weight { Hat, Gaussian, NoiseOptimal }
}

crate::choice! {
    /// Whether frames that disagree with the reference at a pixel are dropped.
    pub enum Deghost { None, Consistency }
}

/// The weight of code `z` in a frame of exposure `t` (the longest being `t_max`).
pub fn weight(w: Weight, z: usize, max: usize, t: f64, t_max: f64) -> f64 {
    if z == 0 || z >= max {
        return 0.0;
    }
    match w {
        Weight::Hat => z.min(max - z) as f64 / (max as f64 / 2.0),
        Weight::Gaussian => {
            let e4 = 4f64.exp();
            let v = 4.0 * z as f64 / max as f64 - 2.0;
            ((e4 * (-v * v).exp() - 1.0) / (e4 - 1.0)).max(0.0)
        }
        Weight::NoiseOptimal => t / t_max,
    }
}

/// What a merge makes: row-major RGB radiance, and per pixel the confidence and the
/// saturated mask (1 or 0), with counts for the metrics.
#[derive(Clone, Debug, PartialEq)]
pub struct Merged {
    pub image: Vec<f32>,
    /// Per pixel (empty when [`Maps::confidence`] is false).
    pub confidence: Vec<f32>,
    /// Per pixel (empty when [`Maps::saturated`] is false).
    pub saturated: Vec<f32>,
    /// The sum of the confidence over the pixels (computed either way, for the metrics).
    pub confidence_sum: f64,
    /// Pixels with a channel at the top code in every frame.
    pub saturated_pixels: usize,
    /// Pixels with a channel at code 0 in every frame.
    pub dark_pixels: usize,
    /// (pixel, frame) pairs dropped by deghosting.
    pub dropped: usize,
}

/// Which per-pixel maps a merge fills besides the image: a pipeline that reads neither saves
/// their memory (a 24-megapixel merge: 192 MB).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Maps {
    pub confidence: bool,
    pub saturated: bool,
}

impl Maps {
    pub const ALL: Maps = Maps { confidence: true, saturated: true };
}

#[derive(Clone, Copy, Default)]
struct RowStats {
    confidence: f64,
    saturated: usize,
    dark: usize,
    dropped: usize,
}

/// One frame's codes as a slice of `u8` or `u16`.
trait Code: Copy + Sync {
    fn idx(self) -> usize;
}
impl Code for u8 {
    #[inline(always)]
    fn idx(self) -> usize {
        self as usize
    }
}
impl Code for u16 {
    #[inline(always)]
    fn idx(self) -> usize {
        self as usize
    }
}

/// The tables of one merge: `lut[(f * 3 + c) * n + z] = (w, x / t)`, `q` likewise.
struct Tables {
    n: usize,
    lut: Vec<[f32; 2]>,
    q: Vec<f32>,
}

fn tables(b: &Brackets, r: &Response, w: Weight, deghost: bool) -> Tables {
    let max = max_code(b.bit_depth);
    let n = max + 1;
    let t_max = b.frames.iter().map(|f| f.time).fold(0.0, f64::max);
    let mut lut = Vec::with_capacity(b.frames.len() * 3 * n);
    let mut q = Vec::new();
    for f in &b.frames {
        for x in &r.x {
            for z in 0..n {
                lut.push([weight(w, z, max, f.time, t_max) as f32, (x[z] / f.time) as f32]);
                if deghost {
                    q.push(((x[(z + 1).min(max)] - x[z.saturating_sub(1)]) / 4.0 / f.time) as f32);
                }
            }
        }
    }
    Tables { n, lut, q }
}

/// Merges `b` with response `r` (same bit depth, checked by the caller), see the module
/// documentation.
pub fn merge(b: &Brackets, r: &Response, w: Weight, deghost: Deghost) -> Merged {
    merge_maps(b, r, w, deghost, Maps::ALL)
}

/// [`merge`], filling only the per-pixel `maps` asked for (the image, counts and confidence
/// sum are the same either way).
pub fn merge_maps(b: &Brackets, r: &Response, w: Weight, deghost: Deghost, maps: Maps) -> Merged {
    match &b.frames[0].codes {
        Codes::U8(_) => {
            let frames: Vec<&[u8]> =
                b.frames.iter().map(|f| if let Codes::U8(v) = &f.codes { v.as_slice() } else { &[] }).collect();
            merge_typed(b, &frames, r, w, deghost, maps)
        }
        Codes::U16(_) => {
            let frames: Vec<&[u16]> =
                b.frames.iter().map(|f| if let Codes::U16(v) = &f.codes { v.as_slice() } else { &[] }).collect();
            merge_typed(b, &frames, r, w, deghost, maps)
        }
    }
}

fn merge_typed<T: Code>(
    b: &Brackets,
    frames: &[&[T]],
    r: &Response,
    w: Weight,
    deghost: Deghost,
    maps: Maps,
) -> Merged {
    let (width, height) = (b.width, b.height);
    let deghost = deghost == Deghost::Consistency && frames.len() > 2;
    let tab = tables(b, r, w, deghost);
    let covered: Vec<Option<&[u8]>> = b.frames.iter().map(|f| f.covered.as_deref()).collect();
    let any_mask = covered.iter().any(Option::is_some);
    let max = max_code(b.bit_depth);
    let mut image = vec![0f32; width * height * 3];
    let map = |want: bool| vec![0f32; if want { width * height } else { 0 }];
    let (mut confidence, mut saturated) = (map(maps.confidence), map(maps.saturated));
    let (conf_rows, sat_rows) = (map_rows(&mut confidence, width, height), map_rows(&mut saturated, width, height));
    let stats = image
        .par_chunks_mut(width * 3)
        .zip(conf_rows)
        .zip(sat_rows)
        .enumerate()
        .map(|(y, ((out, mut conf), mut sat))| {
            let mut s = RowStats::default();
            let mut scratch = Scratch::new(frames.len());
            for x in 0..width {
                let p = y * width + x;
                let own = |f: usize| covered[f].is_none_or(|m| m[p] != 0);
                // No mask: every frame; no frame covers the pixel: every frame too.
                let every = !any_mask || !(0..frames.len()).any(own);
                let use_frame = |f: usize| every || own(f);
                if deghost {
                    s.dropped += scratch.consistency(frames, &tab, p, &use_frame);
                }
                let mut csum = 0f32;
                let mut px_sat = false;
                let mut px_dark = false;
                for c in 0..3 {
                    let i = p * 3 + c;
                    let (mut sw, mut sv) = (0f32, 0f32);
                    for (f, codes) in frames.iter().enumerate() {
                        if !use_frame(f) || (deghost && scratch.dropped[f]) {
                            continue;
                        }
                        let [wz, v] = tab.lut[(f * 3 + c) * tab.n + codes[i].idx()];
                        sw += wz;
                        sv += wz * v;
                    }
                    out[x * 3 + c] = if sw > 0.0 {
                        csum += sw;
                        sv / sw
                    } else {
                        let (v, top, dark) = fallback(frames, &tab, i, c, max, &use_frame);
                        px_sat |= top;
                        px_dark |= dark;
                        v
                    };
                }
                s.confidence += (csum / 3.0) as f64;
                if let Some(conf) = conf.as_deref_mut() {
                    conf[x] = csum / 3.0;
                }
                if let Some(sat) = sat.as_deref_mut() {
                    sat[x] = if px_sat { 1.0 } else { 0.0 };
                }
                s.saturated += px_sat as usize;
                s.dark += (px_dark && !px_sat) as usize;
            }
            s
        })
        .reduce(RowStats::default, |a, b| RowStats {
            confidence: a.confidence + b.confidence,
            saturated: a.saturated + b.saturated,
            dark: a.dark + b.dark,
            dropped: a.dropped + b.dropped,
        });
    Merged {
        image,
        confidence,
        saturated,
        confidence_sum: stats.confidence,
        saturated_pixels: stats.saturated,
        dark_pixels: stats.dark,
        dropped: stats.dropped,
    }
}

/// Each row's slice of a per-pixel map, or `None` per row for a map not asked for (empty).
fn map_rows(v: &mut [f32], width: usize, height: usize) -> Vec<Option<&mut [f32]>> {
    if v.is_empty() {
        (0..height).map(|_| None).collect()
    } else {
        v.chunks_mut(width).map(Some).collect()
    }
}

/// A channel whose weights sum to 0: (value, saturated in every frame, dark in every frame).
fn fallback<T: Code>(
    frames: &[&[T]],
    tab: &Tables,
    i: usize,
    c: usize,
    max: usize,
    use_frame: &impl Fn(usize) -> bool,
) -> (f32, bool, bool) {
    let used = || (0..frames.len()).filter(|&f| use_frame(f));
    let value = |f: usize| tab.lut[(f * 3 + c) * tab.n + frames[f][i].idx()][1];
    if used().all(|f| frames[f][i].idx() >= max) {
        let first = used().next().unwrap_or(0);
        return (value(first), true, false);
    }
    let dark = used().all(|f| frames[f][i].idx() == 0);
    let last = used().filter(|&f| frames[f][i].idx() < max).last().unwrap_or(0);
    (value(last), false, dark)
}

/// Per-pixel deghosting state: which frames are dropped at the current pixel.
struct Scratch {
    dropped: Vec<bool>,
}

impl Scratch {
    fn new(n: usize) -> Scratch {
        Scratch { dropped: vec![false; n] }
    }

    /// Marks the frames that disagree with the reference at pixel `p` (module documentation);
    /// returns how many.
    fn consistency<T: Code>(
        &mut self,
        frames: &[&[T]],
        tab: &Tables,
        p: usize,
        use_frame: &impl Fn(usize) -> bool,
    ) -> usize {
        self.dropped.iter_mut().for_each(|d| *d = false);
        let n = frames.len();
        let entry = |f: usize, c: usize| {
            let k = (f * 3 + c) * tab.n + frames[f][p * 3 + c].idx();
            (tab.lut[k], tab.q[k])
        };
        let good = |f: usize| use_frame(f) && (0..3).all(|c| entry(f, c).0[0] > 0.0);
        let mid = (n - 1) / 2;
        let Some(reference) = (0..n)
            .map(|k| if k % 2 == 0 { mid + k / 2 } else { mid.wrapping_sub(k / 2 + 1) })
            .filter(|&f| f < n)
            .find(|&f| good(f))
        else {
            return 0;
        };
        let mut count = 0;
        for f in (0..n).filter(|&f| f != reference && use_frame(f)) {
            let disagree = (0..3).any(|c| {
                let ([wf, vf], qf) = entry(f, c);
                let ([_, vr], qr) = entry(reference, c);
                wf > 0.0 && (vf - vr).abs() > 3.0 * (qf + qr) + 0.1 * vf.max(vr)
            });
            self.dropped[f] = disagree;
            count += disagree as usize;
        }
        count
    }
}
