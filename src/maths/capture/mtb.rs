//! Ward's median threshold bitmaps (Ward 2003, "Fast, robust image registration for compositing
//! high dynamic range photographs from hand-held exposures", JGT 8(2)), step for step as OpenCV's
//! `AlignMTB::calculateShift` (modules/photo/src/align.cpp), with the bitmaps packed 64 pixels to
//! a `u64` word so that a whole row's comparison is a few XOR, AND and popcount instructions.
//!
//! - **Grey**: OpenCV's `cvtColor(RGB2GRAY)` in fixed point,
//!   `g = (4899 R + 9617 G + 1868 B + 8192) >> 14` (0.299, 0.587, 0.114 times 2^14, rounded). A
//!   16-bit frame is converted by the same formula and its top 8 bits kept (`>> 8`): OpenCV's
//!   median histogram has 256 bins and refuses nothing but would misread 16-bit grey.
//! - **Pyramid**: level l + 1 is level l's every second pixel in both directions (the top-left of
//!   each 2 x 2 block, no filtering), `floor(w / 2) x floor(h / 2)`, down to level
//!   `L = min(floor(log2(max(w, h))) - 1, max_bits - 1)`, and (a deviation, for small images
//!   only) no deeper than leaves 8 pixels on the shorter side ([`max_level`]).
//! - **Median**: OpenCV's `getMedian`, the grey histogram's middle as it computes it: add the bins
//!   from 0 up while the sum is below `floor(pixels / 2)`, and return the index one past the last
//!   bin added (so a flat grey g gives g + 1).
//! - **Bitmaps**: threshold `tb = g > median`, exclusion `eb = |g - median| > exclude_range` (4).
//! - **Search**: from level L down to 0 the shift is doubled and the nine shifts (s + (i, j)),
//!   i, j in {-1, 0, 1}, are scored by `popcount((tb1 XOR shift(tb2)) AND eb1 AND shift(eb2))`,
//!   `shift` moving the bitmap by (dx, dy) and filling with 0 (so uncovered pixels are excluded).
//!   The smallest count wins. **Ties** (a deviation): OpenCV takes the first minimum in the order i
//!   (x) outer, j (y) inner, from -1, so on a level where every count ties (a flat frame: no pixel
//!   escapes the exclusion) it moves by (-1, -1), and a flat frame comes out shifted by (-63, -63);
//!   here a tie goes to (0, 0) first and then to OpenCV's order, so a flat frame stays put and
//!   every shift where the minimum is unique is OpenCV's.
//!
//! The result (dx, dy) is the translation that aligns the second image with the first:
//! `aligned(x, y) = img1(x - dx, y - dy)`; the search reaches `2^max_bits - 1` pixels.

use rayon::prelude::*;

use crate::values::brackets::Codes;

/// OpenCV's `R2Y`, `G2Y`, `B2Y` (imgproc/src/color.hpp): Rec. 601 luma weights times 2^14.
const GREY_WEIGHTS: [u32; 3] = [4899, 9617, 1868];
/// OpenCV's `yuv_shift`.
const GREY_SHIFT: u32 = 14;

/// Ward's and OpenCV's default exclusion range: grey levels within 4 of the median are noise.
pub const EXCLUDE_RANGE: u8 = 4;

/// A one-channel 8-bit image, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Grey {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u8>,
}

impl Grey {
    /// The frame's grey (see the module documentation), computed in parallel by rows.
    pub fn of_codes(codes: &Codes, width: usize, height: usize) -> Grey {
        let luma = |r: u32, g: u32, b: u32| {
            (r * GREY_WEIGHTS[0] + g * GREY_WEIGHTS[1] + b * GREY_WEIGHTS[2] + (1 << (GREY_SHIFT - 1))) >> GREY_SHIFT
        };
        let mut data = vec![0u8; width * height];
        let row = width.max(1);
        match codes {
            Codes::U8(v) => data.par_chunks_mut(row).zip(v.par_chunks(3 * row)).for_each(|(out, rgb)| {
                for (o, p) in out.iter_mut().zip(rgb.chunks_exact(3)) {
                    *o = luma(p[0] as u32, p[1] as u32, p[2] as u32) as u8;
                }
            }),
            Codes::U16(v) => data.par_chunks_mut(row).zip(v.par_chunks(3 * row)).for_each(|(out, rgb)| {
                for (o, p) in out.iter_mut().zip(rgb.chunks_exact(3)) {
                    *o = (luma(p[0] as u32, p[1] as u32, p[2] as u32) >> 8) as u8;
                }
            }),
        }
        Grey { width, height, data }
    }

    /// Every second pixel of every second row (OpenCV's `downsample`).
    fn downsample(&self) -> Grey {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut data = vec![0u8; w * h];
        data.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
            let src = &self.data[2 * y * self.width..];
            for (x, o) in row.iter_mut().enumerate() {
                *o = src[2 * x];
            }
        });
        Grey { width: w, height: h, data }
    }

    /// OpenCV's `getMedian` (see the module documentation).
    pub fn median(&self) -> u16 {
        let mut hist = [0usize; 256];
        for &g in &self.data {
            hist[g as usize] += 1;
        }
        let thresh = self.data.len() / 2;
        let (mut median, mut sum) = (0u16, 0usize);
        while sum < thresh && median < 256 {
            sum += hist[median as usize];
            median += 1;
        }
        median
    }
}

/// The shorter side, in pixels, below which a pyramid level is not searched (see
/// [`max_level`]).
pub const MIN_LEVEL_SIDE: usize = 8;

/// The deepest pyramid level searched for a `width x height` image: OpenCV's
/// `min(floor(log2(max(w, h))) - 1, max_bits - 1)`, further capped so that the coarsest level's
/// shorter side keeps [`MIN_LEVEL_SIDE`] pixels (at least level 0 is searched). OpenCV's
/// coarsest levels can be a few pixels wide, where a 9-way search of a 3 x 2 bitmap moves the
/// result by 2^level pixels at random; the cap changes nothing once the shorter side reaches
/// `8 * 2^(max_bits - 1)` (256 pixels for the default), so camera frames align as in OpenCV.
/// -1 (no search) for an empty or 1 x 1 image.
pub fn max_level(width: usize, height: usize, max_bits: u32) -> i32 {
    let (long, short) = (width.max(height), width.min(height));
    if short == 0 {
        return -1;
    }
    // OpenCV: (int)(log((double)max(rows, cols)) / log(2.0)) - 1, the same libm expression.
    let opencv = (((long as f64).ln() / 2f64.ln()) as i32 - 1).min(max_bits as i32 - 1);
    let by_short = (short.ilog2() as i32 - MIN_LEVEL_SIDE.ilog2() as i32).max(0);
    opencv.min(by_short)
}

/// The threshold and exclusion bitmaps of one pyramid level, bit x % 64 of word x / 64 of each
/// row; bits past the width are 0.
#[derive(Clone, Debug)]
pub struct Bitmaps {
    pub width: usize,
    pub height: usize,
    pub words: usize,
    pub tb: Vec<u64>,
    pub eb: Vec<u64>,
}

impl Bitmaps {
    pub fn of(img: &Grey, exclude_range: u8) -> Bitmaps {
        let median = img.median() as i32;
        let words = img.width.div_ceil(64);
        let mut tb = vec![0u64; words * img.height];
        let mut eb = vec![0u64; words * img.height];
        if words > 0 {
            tb.par_chunks_mut(words).zip(eb.par_chunks_mut(words)).enumerate().for_each(|(y, (t, e))| {
                let row = &img.data[y * img.width..(y + 1) * img.width];
                for (x, &g) in row.iter().enumerate() {
                    let g = g as i32;
                    t[x / 64] |= ((g > median) as u64) << (x % 64);
                    e[x / 64] |= (((g - median).abs() > exclude_range as i32) as u64) << (x % 64);
                }
            });
        }
        Bitmaps { width: img.width, height: img.height, words, tb, eb }
    }

    /// The 64 bits of row `row` (a slice of `words` words) that land in word `w` after moving the
    /// row right by `dx` pixels: source bits `64 w - dx ..`, 0 where they fall outside the row.
    #[inline]
    fn shifted_word(row: &[u64], w: usize, dx: i64) -> u64 {
        let start = 64 * w as i64 - dx;
        let (q, r) = (start.div_euclid(64), start.rem_euclid(64) as u32);
        let get = |k: i64| if k >= 0 && (k as usize) < row.len() { row[k as usize] } else { 0 };
        let lo = get(q) >> r;
        if r == 0 {
            lo
        } else {
            lo | (get(q + 1) << (64 - r))
        }
    }

    /// OpenCV's error count for moving `other` by (dx, dy) onto `self`: the pixels where the
    /// threshold bits differ and neither is excluded.
    pub fn mismatch(&self, other: &Bitmaps, dx: i64, dy: i64) -> u64 {
        let n = self.words;
        (0..self.height)
            .into_par_iter()
            .map(|y| {
                let sy = y as i64 - dy;
                if sy < 0 || sy >= other.height as i64 {
                    return 0;
                }
                let sy = sy as usize;
                let (t1, e1) = (&self.tb[y * n..(y + 1) * n], &self.eb[y * n..(y + 1) * n]);
                let (t2, e2) = (&other.tb[sy * n..(sy + 1) * n], &other.eb[sy * n..(sy + 1) * n]);
                let mut count = 0u64;
                for w in 0..n {
                    let (tw, ew) = (Self::shifted_word(t2, w, dx), Self::shifted_word(e2, w, dx));
                    count += ((t1[w] ^ tw) & e1[w] & ew).count_ones() as u64;
                }
                count
            })
            .sum()
    }
}

/// The pyramid of grey images, level 0 the image itself, down to `max_level` (none when it is
/// negative).
pub fn pyramid(img: Grey, max_level: i32) -> Vec<Grey> {
    let mut pyr = vec![img];
    for _ in 0..max_level.max(0) {
        let next = pyr.last().expect("the pyramid starts with the image").downsample();
        pyr.push(next);
    }
    pyr
}

/// The shift (dx, dy) that aligns `img1` with `img0` (OpenCV's `calculateShift`, the tie rule of
/// the module documentation), both of one size. The pyramids are built to `max_level(.., max_bits)`.
pub fn calculate_shift(img0: &Grey, img1: &Grey, max_bits: u32, exclude_range: u8) -> (i64, i64) {
    let level = max_level(img0.width, img0.height, max_bits);
    let pyr0 = pyramid(img0.clone(), level);
    let pyr1 = pyramid(img1.clone(), level);
    shift_between(&pyr0, &pyr1, exclude_range)
}

/// [`calculate_shift`] on pyramids built once (the reference's is shared by every frame).
pub fn shift_between(pyr0: &[Grey], pyr1: &[Grey], exclude_range: u8) -> (i64, i64) {
    let (mut sx, mut sy) = (0i64, 0i64);
    for (l0, l1) in pyr0.iter().zip(pyr1).rev() {
        sx *= 2;
        sy *= 2;
        let (b0, b1) = (Bitmaps::of(l0, exclude_range), Bitmaps::of(l1, exclude_range));
        let mut best = (b0.mismatch(&b1, sx, sy), (0, 0));
        for i in -1..=1 {
            for j in -1..=1 {
                if (i, j) == (0, 0) {
                    continue;
                }
                let err = b0.mismatch(&b1, sx + i, sy + j);
                if err < best.0 {
                    best = (err, (i, j));
                }
            }
        }
        sx += best.1 .0;
        sy += best.1 .1;
    }
    (sx, sy)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(width: usize, height: usize, f: impl Fn(usize, usize) -> u8) -> Grey {
        let data = (0..width * height).map(|i| f(i % width, i / width)).collect();
        Grey { width, height, data }
    }

    /// The plain byte-per-pixel count of OpenCV's loop: shiftMat (zero fill), XOR, AND, AND.
    fn naive_mismatch(a: &Grey, b: &Grey, dx: i64, dy: i64) -> u64 {
        let median = |g: &Grey| g.median() as i32;
        let (ma, mb) = (median(a), median(b));
        let mut count = 0;
        for y in 0..a.height as i64 {
            for x in 0..a.width as i64 {
                let (sx, sy) = (x - dx, y - dy);
                if sx < 0 || sy < 0 || sx >= b.width as i64 || sy >= b.height as i64 {
                    continue;
                }
                let ga = a.data[(y * a.width as i64 + x) as usize] as i32;
                let gb = b.data[(sy * b.width as i64 + sx) as usize] as i32;
                let (ta, tb) = (ga > ma, gb > mb);
                if ta != tb && (ga - ma).abs() > 4 && (gb - mb).abs() > 4 {
                    count += 1;
                }
            }
        }
        count
    }

    fn hash(x: usize, y: usize) -> u8 {
        let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        (h >> 56) as u8
    }

    #[test]
    fn the_grey_is_opencvs_fixed_point_luma() {
        let codes = Codes::U8(vec![255, 255, 255, 0, 0, 0, 255, 0, 0, 10, 200, 30]);
        let g = Grey::of_codes(&codes, 2, 2);
        // 4899 * 255 + 8192 >> 14 = 76; 10, 200, 30: (48990 + 1923400 + 56040 + 8192) >> 14 = 124.
        assert_eq!(g.data, vec![255, 0, 76, 124]);
        let wide = Codes::U16(vec![65535, 65535, 65535, 0, 0, 0]);
        assert_eq!(Grey::of_codes(&wide, 2, 1).data, vec![255, 0]);
    }

    #[test]
    fn the_median_is_one_past_the_middle_bin_as_in_opencv() {
        assert_eq!(grey(4, 4, |_, _| 100).median(), 101);
        // 0..16: thresh 8, bins 0..=7 reach 8, the index after is 8.
        assert_eq!(grey(4, 4, |x, y| (4 * y + x) as u8).median(), 8);
        assert_eq!(grey(1, 1, |_, _| 7).median(), 0);
    }

    #[test]
    fn the_depth_follows_opencv_and_caps_at_the_image_size() {
        assert_eq!(max_level(6000, 4000, 6), 5);
        assert_eq!(max_level(6000, 4000, 12), 8);
        assert_eq!(max_level(256, 256, 6), 5, "OpenCV's depth from a shorter side of 256");
        assert_eq!(max_level(40, 30, 6), 1, "OpenCV: 4, leaving 2 x 1 pixels");
        assert_eq!(max_level(24, 20, 6), 1);
        assert_eq!(max_level(7, 3, 6), 0);
        assert_eq!(max_level(1, 1, 6), -1);
        assert_eq!(max_level(0, 0, 6), -1);
        assert_eq!(max_level(1024, 1, 12), 0);
    }

    #[test]
    fn packed_counts_equal_the_byte_per_pixel_count_for_every_shift() {
        // Widths across word boundaries, shifts past a word.
        for (w, h) in [(1, 1), (63, 5), (64, 4), (65, 3), (130, 7), (200, 2)] {
            let a = grey(w, h, hash);
            let b = grey(w, h, |x, y| hash(x + 3, y + 1).wrapping_add(9));
            let (ba, bb) = (Bitmaps::of(&a, 4), Bitmaps::of(&b, 4));
            for (dx, dy) in [(0, 0), (1, 0), (-1, 1), (63, 0), (-64, -1), (65, 2), (-70, 0), (3, -3), (500, 0)] {
                assert_eq!(ba.mismatch(&bb, dx, dy), naive_mismatch(&a, &b, dx, dy), "{w}x{h} by ({dx}, {dy})");
            }
        }
    }

    #[test]
    fn a_flat_or_empty_image_stays_put() {
        let flat = grey(50, 40, |_, _| 128);
        let tex = grey(50, 40, hash);
        assert_eq!(calculate_shift(&flat, &flat, 6, 4), (0, 0));
        assert_eq!(calculate_shift(&tex, &flat, 6, 4), (0, 0));
        assert_eq!(calculate_shift(&flat, &tex, 6, 4), (0, 0));
        let empty = grey(0, 0, |_, _| 0);
        assert_eq!(calculate_shift(&empty, &empty, 6, 4), (0, 0));
        let line = grey(9, 1, hash);
        assert_eq!(calculate_shift(&line, &line, 6, 4), (0, 0));
    }
}
