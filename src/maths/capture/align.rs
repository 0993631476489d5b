//! Aligning a bracket by translation, as OpenCV's `AlignMTB::process`: every frame is moved onto
//! the reference frame, the one at index `n / 2` of the frames (sorted by exposure time, so the
//! middle exposure), by the shift `mtb::shift_between` finds between their median threshold
//! bitmaps (`crate::maths::capture::mtb`): against the reference itself (OpenCV's pairing,
//! [`Pairing::Reference`]) or, by default, against the neighbour one exposure step nearer to it,
//! the steps added up ([`Pairing::Chained`]).
//!
//! A frame moved by (dx, dy) keeps its size: `aligned(x, y) = frame(x - dx, y - dy)` where that
//! pixel exists, and elsewhere the nearest edge pixel, `frame(clamp(x - dx), clamp(y - dy))`
//! (OpenCV fills with black, which a merge would read as a dark exposure), with its `covered`
//! mask 0 there (and the frame's own mask, if it had one, moved along). The reference and frames
//! that do not move are left as they are.
//!
//! `max_shift` sets Ward's `max_bits = ceil(log2(max_shift))` (at least 1), so the default 64 is
//! OpenCV's default `max_bits` 6: the search reaches `2^max_bits - 1` = 63 pixels; the pyramid's
//! depth is further capped by the image's size (`mtb::max_level`).

use rayon::prelude::*;

use crate::maths::capture::mtb::{max_level, pyramid, shift_between, Grey, EXCLUDE_RANGE};
use crate::values::brackets::{Brackets, Codes, Frame};

/// Ward's `max_bits` for a largest wanted shift: the smallest b >= 1 with 2^b >= max_shift.
pub fn max_bits_for(max_shift: u32) -> u32 {
    max_shift.max(2).next_power_of_two().trailing_zeros()
}

/// The index of the reference frame of `n` frames (OpenCV's pivot).
pub fn reference_index(n: usize) -> usize {
    n / 2
}

crate::choice! {
    /// Which pairs of frames are compared.
    pub enum Pairing {
        /// Each frame against its neighbour towards the reference (one exposure step nearer), the
        /// shifts added along the chain: neighbours share most of their well-exposed pixels, where the
        /// shortest exposure of a bracket against the middle one is mostly black and its bitmap mostly
        /// noise (on the capture example's park ball, OpenCV's pairing moves the 1/4000 s frame by
        /// (-12, -4) instead of (-2, 1); `tests/capture_example.rs`).
        Chained,
        /// Every frame against the reference, as OpenCV's `AlignMTB::process`.
        Reference,
    }
}

/// The shift (dx, dy) of every frame onto the reference, in the frames' order (the reference's
/// is (0, 0)). Frames are compared in parallel.
pub fn bracket_shifts(b: &Brackets, max_shift: u32, pairing: Pairing) -> Vec<(i64, i64)> {
    if b.frames.is_empty() {
        return Vec::new();
    }
    let level = max_level(b.width, b.height, max_bits_for(max_shift));
    let pivot = reference_index(b.frames.len());
    let pyrs: Vec<_> =
        b.frames.par_iter().map(|f| pyramid(Grey::of_codes(&f.codes, b.width, b.height), level)).collect();
    // The frame each frame is compared with: the reference, or the next one towards it.
    let target = |k: usize| match pairing {
        Pairing::Reference => pivot,
        Pairing::Chained if k < pivot => k + 1,
        Pairing::Chained => k - 1,
    };
    let steps: Vec<(i64, i64)> = (0..pyrs.len())
        .into_par_iter()
        .map(|k| if k == pivot { (0, 0) } else { shift_between(&pyrs[target(k)], &pyrs[k], EXCLUDE_RANGE) })
        .collect();
    // A chained frame moves onto its neighbour, which itself moves onto the reference.
    let mut shifts = steps.clone();
    for k in (0..pivot).rev() {
        let next = shifts[target(k)];
        shifts[k] = (steps[k].0 + next.0, steps[k].1 + next.1);
    }
    for k in pivot + 1..shifts.len() {
        let prev = shifts[target(k)];
        shifts[k] = (steps[k].0 + prev.0, steps[k].1 + prev.1);
    }
    shifts
}

/// Moves `frame` (of `width x height` pixels) by (dx, dy) as the module documentation says.
pub fn shift_frame(frame: &mut Frame, width: usize, height: usize, (dx, dy): (i64, i64)) {
    if (dx, dy) == (0, 0) || width == 0 || height == 0 {
        return;
    }
    let source = |x: usize, y: usize| -> (usize, usize, bool) {
        let (sx, sy) = (x as i64 - dx, y as i64 - dy);
        let inside = sx >= 0 && sy >= 0 && sx < width as i64 && sy < height as i64;
        (sx.clamp(0, width as i64 - 1) as usize, sy.clamp(0, height as i64 - 1) as usize, inside)
    };
    fn moved<T: Copy + Send + Sync>(
        v: &[T],
        width: usize,
        src: impl Fn(usize, usize) -> (usize, usize) + Sync,
    ) -> Vec<T> {
        let mut out = v.to_vec();
        out.par_chunks_mut(3 * width).enumerate().for_each(|(y, row)| {
            for x in 0..width {
                let (sx, sy) = src(x, y);
                let s = 3 * (sy * width + sx);
                row[3 * x..3 * x + 3].copy_from_slice(&v[s..s + 3]);
            }
        });
        out
    }
    let src = |x, y| {
        let (sx, sy, _) = source(x, y);
        (sx, sy)
    };
    frame.codes = match &frame.codes {
        Codes::U8(v) => Codes::U8(moved(v, width, src)),
        Codes::U16(v) => Codes::U16(moved(v, width, src)),
    };
    let old = frame.covered.take();
    let mut covered = vec![0u8; width * height];
    covered.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (x, c) in row.iter_mut().enumerate() {
            let (sx, sy, inside) = source(x, y);
            *c = (inside && old.as_ref().is_none_or(|m| m[sy * width + sx] != 0)) as u8;
        }
    });
    frame.covered = Some(covered);
}

/// Aligns every frame of `b` onto its reference (module documentation); returns the shifts.
pub fn align_brackets(b: &mut Brackets, max_shift: u32, pairing: Pairing) -> Vec<(i64, i64)> {
    let shifts = bracket_shifts(b, max_shift, pairing);
    let (w, h) = (b.width, b.height);
    for (f, &s) in b.frames.iter_mut().zip(&shifts) {
        shift_frame(f, w, h, s);
    }
    shifts
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured scene radiance on a large canvas, 0.05 to 0.4: random piecewise-constant cells
    /// at six scales, 3 to 97 pixels, whose grids do not line up (sharp edges, as photographs have).
    fn scene(x: i64, y: i64) -> f64 {
        cells(x, y, &[97, 53, 29, 13, 7, 3])
    }

    /// The same at the four finest scales only, 3 to 13 pixels (for frames of a few cells).
    fn fine_scene(x: i64, y: i64) -> f64 {
        cells(x, y, &[13, 7, 5, 3])
    }

    fn cells(x: i64, y: i64, sizes: &[i64]) -> f64 {
        fn lattice(ix: i64, iy: i64, seed: u64) -> f64 {
            let mut h = (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
                ^ seed.wrapping_mul(0x1656_67B1_9E37_79F9);
            h ^= h >> 31;
            h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            h ^= h >> 29;
            (h >> 11) as f64 / (1u64 << 53) as f64
        }
        let mut v = 0.0;
        for (k, &cell) in sizes.iter().enumerate() {
            v += lattice(x.div_euclid(cell), y.div_euclid(cell), k as u64);
        }
        0.05 * 8f64.powf(v / sizes.len() as f64)
    }

    /// 8-bit sRGB-like frames (gamma 2.2) of the scene at `times`, frame k's window offset by
    /// `offsets[k]` (so its content moves by minus that offset).
    fn frames(w: usize, h: usize, times: &[f64], offsets: &[(i64, i64)]) -> Brackets {
        frames_of(scene, w, h, times, offsets)
    }

    fn frames_of(scene: fn(i64, i64) -> f64, w: usize, h: usize, times: &[f64], offsets: &[(i64, i64)]) -> Brackets {
        let frames = times
            .iter()
            .zip(offsets)
            .enumerate()
            .map(|(k, (&t, &(ox, oy)))| {
                let mut codes = Vec::with_capacity(w * h * 3);
                for y in 0..h as i64 {
                    for x in 0..w as i64 {
                        let l = scene(x + ox, y + oy) * t;
                        for tint in [1.0, 0.9, 0.7] {
                            codes.push((255.0 * (l * tint).min(1.0).powf(1.0 / 2.2)).round() as u8);
                        }
                    }
                }
                Frame { name: format!("f{k}.jpg"), time: t, codes: Codes::U8(codes), covered: None }
            })
            .collect();
        Brackets::new(w, h, 8, frames).unwrap()
    }

    #[test]
    fn max_bits_follow_max_shift() {
        assert_eq!(max_bits_for(64), 6);
        assert_eq!(max_bits_for(63), 6);
        assert_eq!(max_bits_for(65), 7);
        assert_eq!(max_bits_for(1), 1);
        assert_eq!(max_bits_for(2), 1);
        assert_eq!(max_bits_for(3), 2);
    }

    #[test]
    fn known_shifts_between_exposures_are_recovered_exactly() {
        let times = [0.25, 0.5, 1.0, 2.0, 4.0];
        let offsets = [(7, -3), (-12, 5), (0, 0), (1, 1), (-30, -21)];
        let mut b = frames(480, 360, &times, &offsets);
        let shifts = align_brackets(&mut b, 64, Pairing::Chained);
        // Frame k shows the scene at (x + o_k); moved by (dx, dy) it matches the reference (o = 0)
        // when dx = o_k.
        assert_eq!(shifts, offsets.to_vec());
        let f = &b.frames[4];
        let m = f.covered.as_ref().unwrap();
        // Moved left by 30 and up by 21: the last 30 columns and 21 rows are filled, marked 0.
        assert_eq!(m[350 * 480 + 100], 0);
        assert_eq!(m[100 * 480 + 450], 0);
        assert_eq!(m[100 * 480 + 449], 1);
        assert_eq!(m.iter().filter(|&&c| c == 1).count(), (480 - 30) * (360 - 21));
        assert!(b.frames[2].covered.is_none(), "the reference is untouched");
    }

    #[test]
    fn a_moved_frame_keeps_its_size_and_fills_from_the_edge() {
        let codes: Vec<u8> = (0..4 * 3 * 3).map(|i| i as u8).collect();
        let mut f = Frame { name: "a".into(), time: 1.0, codes: Codes::U8(codes.clone()), covered: None };
        shift_frame(&mut f, 4, 3, (1, -1));
        let Codes::U8(v) = &f.codes else { unreachable!() };
        let px = |x: usize, y: usize| v[3 * (y * 4 + x)];
        let src = |x: usize, y: usize| codes[3 * (y * 4 + x)];
        assert_eq!(px(1, 0), src(0, 1));
        assert_eq!(px(0, 0), src(0, 1), "the left column repeats the edge");
        assert_eq!(px(3, 2), src(2, 2), "the bottom row repeats the edge");
        assert_eq!(f.covered.unwrap(), vec![0, 1, 1, 1, 0, 1, 1, 1, 0, 0, 0, 0]);
    }

    #[test]
    fn flat_tiny_and_single_frames_do_not_panic() {
        let flat = |w: usize, h: usize, t: f64, v: u8| Frame {
            name: format!("{t}"),
            time: t,
            codes: Codes::U8(vec![v; w * h * 3]),
            covered: None,
        };
        for (w, h) in [(64, 48), (1, 1), (3, 2), (7, 1), (1, 9), (0, 0)] {
            let mut b =
                Brackets::new(w, h, 8, vec![flat(w, h, 1.0, 40), flat(w, h, 2.0, 90), flat(w, h, 4.0, 200)]).unwrap();
            assert_eq!(align_brackets(&mut b, 64, Pairing::Chained), vec![(0, 0); 3], "{w}x{h}");
        }
        let mut one = Brackets::new(5, 5, 8, vec![flat(5, 5, 1.0, 1)]).unwrap();
        assert_eq!(align_brackets(&mut one, 64, Pairing::Chained), vec![(0, 0)]);
        let mut none = Brackets::new(5, 5, 8, vec![]).unwrap();
        assert!(align_brackets(&mut none, 64, Pairing::Chained).is_empty());
    }

    #[test]
    fn images_smaller_than_the_pyramid_still_align() {
        // 24 x 20: OpenCV would search 3 levels below, down to 3 x 2 pixels; one is searched.
        // (Exposures this close, and fine cells, keep the bitmaps alike: a window of a few large
        // cells has too few edges for the medians of far-apart exposures to agree.)
        let times = [0.95, 1.0, 1.05];
        let offsets = [(2, -1), (0, 0), (-3, 2)];
        let mut b = frames_of(fine_scene, 24, 20, &times, &offsets);
        assert_eq!(align_brackets(&mut b, 64, Pairing::Chained), offsets.to_vec());
    }
}
