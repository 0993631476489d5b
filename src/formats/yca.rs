//! OpenEXR's luminance/chroma reconstruction (`RgbaInputFile` reading a file written by
//! `RgbaOutputFile` with `WRITE_YC`): full-resolution `Y`, 2x2-subsampled `RY` and `BY`.
//!
//! Written by hand because no crate does it: the `exr` crate decodes the subsampled channels
//! (with our patch, `vendor/exr/PATCHES.md`) but leaves reconstruction to the caller. This is a
//! transcription of OpenEXR 3's `ImfRgbaYca.cpp` and `RgbaInputFile::FromYca`
//! (`ImfRgbaFile.cpp`), step for step, so that the result is **the same bits** as OpenEXR's:
//!
//! 1. **Horizontal** (`reconstructChromaHoriz`): on even rows (the ones carrying chroma), the
//!    missing odd-column samples are a 27-tap half-band filter over the even columns (14 non-zero
//!    taps); the row is padded by repeating column 0 on the left and column `w - 2` on the right
//!    (`padTmpBuf`).
//! 2. **Vertical** (`reconstructChromaVert`): odd rows get their chroma from the same filter over
//!    the even rows `y - 13, y - 11, ..., y + 13`; rows outside the image are clamped to row 0
//!    above and row `h - 2` below (`readYCAScanLine`).
//! 3. **To RGB** (`YCAtoRGBA`): `R = (RY + 1) Y`, `B = (BY + 1) Y`,
//!    `G = (Y - R yw.x - B yw.z) / yw.y`; `RY = BY = 0` gives grey `Y` exactly.
//! 4. **Saturation** (`fixSaturation`): a pixel much more saturated than the mean of its four
//!    diagonal neighbours (rows above and below, with the same clamping) is desaturated towards
//!    its maximum component, keeping its luminance: this removes the coloured fringes that
//!    chroma subsampling leaves at sharp edges.
//!
//! Every intermediate OpenEXR stores in a `half` (`Rgba` is four halves) is rounded to half here
//! too, and f32 arithmetic keeps OpenEXR's order of operations (no fused multiply-add), so the
//! output matches `RgbaInputFile` bit for bit; `tests/exr_conformance.rs` checks that against
//! values OpenEXR itself computed (`scripts/openexr-cpp-oracle.cpp`).

use ::exr::prelude::f16;

use super::Primaries;

/// Half of OpenEXR's filter width `N = 27`.
const N2: usize = 13;

/// `reconstructChromaHoriz` / `reconstructChromaVert` weights of the samples at offsets
/// -13, -11, ..., -1, +1, ..., +13 (OpenEXR `ImfRgbaYca.cpp`).
const TAPS: [f32; 14] = [
    0.002128, -0.007540, 0.019597, -0.043159, 0.087929, -0.186077, 0.627123, 0.627123, -0.186077, 0.087929, -0.043159,
    0.019597, -0.007540, 0.002128,
];

/// Rounds to the nearest half (round to nearest even), as a store into an OpenEXR `half` does.
fn half(x: f32) -> f32 {
    f16::from_f32(x).to_f32()
}

/// Every value rounded to half: what OpenEXR's half `Rgba` frame buffer holds.
pub fn round_to_half(values: Vec<f32>) -> Vec<f32> {
    values.into_iter().map(half).collect()
}

/// OpenEXR's luminance weights `yw` (`RgbaYca::computeYw`): the Y row of `RGBtoXYZ(cr, 1)`
/// normalised to sum 1, computed in f32 in OpenEXR's order (`ImfChromaticities.cpp`).
pub fn luminance_weights_f32(p: &Primaries) -> [f32; 3] {
    let f = |v: f64| v as f32;
    let (rx, ry) = (f(p.red[0]), f(p.red[1]));
    let (gx, gy) = (f(p.green[0]), f(p.green[1]));
    let (bx, by) = (f(p.blue[0]), f(p.blue[1]));
    let (wx, wy) = (f(p.white[0]), f(p.white[1]));
    let y = 1.0f32;
    let x = wx * y / wy;
    let z = (1.0 - wx - wy) * y / wy;
    let d = rx * (by - gy) + bx * (gy - ry) + gx * (ry - by);
    let sr_n = x * (by - gy) - gx * (y * (by - 1.0) + by * (x + z)) + bx * (y * (gy - 1.0) + gy * (x + z));
    let sg_n = x * (ry - by) + rx * (y * (by - 1.0) + by * (x + z)) - bx * (y * (ry - 1.0) + ry * (x + z));
    let sb_n = x * (gy - ry) - rx * (y * (gy - 1.0) + gy * (x + z)) + gx * (y * (ry - 1.0) + ry * (x + z));
    let (sr, sg, sb) = (sr_n / d, sg_n / d, sb_n / d);
    let (m01, m11, m21) = (sr * ry, sg * gy, sb * by);
    let sum = m01 + m11 + m21;
    [m01 / sum, m11 / sum, m21 / sum]
}

/// The input planes: `y` at `w x h`; `ry`, `by` at `w/2 x h/2` (OpenEXR requires the data
/// window's size and position to be multiples of the sampling, so `w` and `h` are even). All
/// already rounded to half (OpenEXR converts every channel to half in its `Rgba` frame buffer).
pub struct YcaPlanes<'a> {
    pub width: usize,
    pub height: usize,
    pub y: &'a [f32],
    pub ry: &'a [f32],
    pub by: &'a [f32],
}

/// The offset of tap `k` of [`TAPS`]: -13, -11, ..., -1, +1, ..., +13.
fn tap_offset(k: usize) -> i64 {
    2 * k as i64 - N2 as i64
}

/// `reconstructChromaHoriz` on one stored chroma row (`w/2` samples at the even columns),
/// padded as `padTmpBuf` pads: column 0 repeated on the left, column `w - 2` on the right.
fn reconstruct_horizontal(raw: &[f32], w: usize) -> Vec<f32> {
    let at = |x: i64| -> f32 {
        if x < 0 {
            raw[0]
        } else if x >= w as i64 {
            raw[raw.len() - 1]
        } else {
            raw[x as usize / 2]
        }
    };
    (0..w)
        .map(|x| {
            if x % 2 == 0 {
                raw[x / 2]
            } else {
                let mut sum = 0.0f32;
                for (k, &tap) in TAPS.iter().enumerate() {
                    sum += at(x as i64 + tap_offset(k)) * tap;
                }
                half(sum)
            }
        })
        .collect()
}

impl YcaPlanes<'_> {
    /// The reconstructed RGB image, interleaved `w x h x 3`, as `RgbaInputFile` returns it.
    pub fn to_rgb(&self, primaries: &Primaries) -> Vec<f32> {
        use rayon::prelude::*;
        let yw = luminance_weights_f32(primaries);
        let (w, h) = (self.width, self.height);
        debug_assert!(w >= 2 && h >= 2 && w % 2 == 0 && h % 2 == 0);
        // Horizontally reconstructed chroma of the even rows (`readYCAScanLine`).
        let chroma: Vec<[Vec<f32>; 2]> = (0..h / 2)
            .into_par_iter()
            .map(|j| {
                let row = |plane: &[f32]| reconstruct_horizontal(&plane[j * (w / 2)..(j + 1) * (w / 2)], w);
                [row(self.ry), row(self.by)]
            })
            .collect();
        // `readYCAScanLine`'s clamping: above the image row 0, below it row h - 2.
        let clamp = |row: i64| -> usize {
            if row < 0 {
                0
            } else if row >= h as i64 {
                h - 2
            } else {
                row as usize
            }
        };
        let luminance = |row: usize| &self.y[row * w..(row + 1) * w];
        // `_buf2`: RGB rows -1 ..= h before `fixSaturation`.
        let rgb: Vec<[Vec<f32>; 3]> = (-1..=h as i64)
            .into_par_iter()
            .map(|row| {
                let y = luminance(clamp(row));
                if row.rem_euclid(2) == 0 {
                    let [ry, by] = &chroma[clamp(row) / 2];
                    yca_to_rgb(y, ry, by, yw)
                } else {
                    // `reconstructChromaVert` over the even rows row - 13 ..= row + 13.
                    let taps: Vec<&[Vec<f32>; 2]> =
                        (0..TAPS.len()).map(|k| &chroma[clamp(row + tap_offset(k)) / 2]).collect();
                    let filter = |c: usize| -> Vec<f32> {
                        (0..w)
                            .map(|x| {
                                let mut sum = 0.0f32;
                                for (k, t) in taps.iter().enumerate() {
                                    sum += t[c][x] * TAPS[k];
                                }
                                half(sum)
                            })
                            .collect()
                    };
                    yca_to_rgb(y, &filter(0), &filter(1), yw)
                }
            })
            .collect();
        let mut out = vec![0.0f32; w * h * 3];
        out.par_chunks_mut(w * 3).enumerate().for_each(|(row, line)| {
            // rgb[i] is row i - 1.
            fix_saturation(yw, [&rgb[row], &rgb[row + 1], &rgb[row + 2]], line);
        });
        out
    }
}

/// `YCAtoRGBA` on one row.
fn yca_to_rgb(y: &[f32], ry: &[f32], by: &[f32], yw: [f32; 3]) -> [Vec<f32>; 3] {
    let w = y.len();
    let (mut r, mut g, mut b) = (vec![0.0; w], vec![0.0; w], vec![0.0; w]);
    for x in 0..w {
        let (yv, ryv, byv) = (y[x], ry[x], by[x]);
        if ryv == 0.0 && byv == 0.0 {
            (r[x], g[x], b[x]) = (yv, yv, yv);
        } else {
            let rv = (ryv + 1.0) * yv;
            let bv = (byv + 1.0) * yv;
            let gv = (yv - rv * yw[0] - bv * yw[2]) / yw[1];
            (r[x], g[x], b[x]) = (half(rv), half(gv), half(bv));
        }
    }
    [r, g, b]
}

/// `std::max` (returns the first argument unless it is less than the second).
fn max(a: f32, b: f32) -> f32 {
    if a < b {
        b
    } else {
        a
    }
}

/// `std::min` (returns the first argument unless the second is less).
fn min(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

fn saturation(rgb: [f32; 3]) -> f32 {
    let rgb_max = max(rgb[0], max(rgb[1], rgb[2]));
    let rgb_min = min(rgb[0], min(rgb[1], rgb[2]));
    if rgb_max > 0.0 {
        1.0 - rgb_min / rgb_max
    } else {
        0.0
    }
}

fn desaturate(rgb: [f32; 3], f: f32, yw: [f32; 3]) -> [f32; 3] {
    let rgb_max = max(rgb[0], max(rgb[1], rgb[2]));
    let mut out = rgb.map(|v| half(max(rgb_max - (rgb_max - v) * f, 0.0)));
    let y_in = rgb[0] * yw[0] + rgb[1] * yw[1] + rgb[2] * yw[2];
    let y_out = out[0] * yw[0] + out[1] * yw[1] + out[2] * yw[2];
    if y_out > 0.0 {
        out = out.map(|v| half(v * (y_in / y_out)));
    }
    out
}

/// `fixSaturation`: the middle row, desaturated where it is far more saturated than the mean of
/// its four diagonal neighbours (clamped at the row's ends), into the interleaved RGB `line`.
fn fix_saturation(yw: [f32; 3], rows: [&[Vec<f32>; 3]; 3], line: &mut [f32]) {
    let w = rows[1][0].len();
    let px = |r: &[Vec<f32>; 3], x: usize| [r[0][x], r[1][x], r[2][x]];
    let mut a2 = saturation(px(rows[0], 0));
    let mut a1 = a2;
    let mut b2 = saturation(px(rows[2], 0));
    let mut b1 = b2;
    for x in 0..w {
        let a0 = a1;
        a1 = a2;
        let b0 = b1;
        b1 = b2;
        if x + 1 < w {
            a2 = saturation(px(rows[0], x + 1));
            b2 = saturation(px(rows[2], x + 1));
        }
        let s_mean = min(1.0, 0.25 * (a0 + a2 + b0 + b2));
        let input = px(rows[1], x);
        let s = saturation(input);
        let mut value = input;
        if s > s_mean {
            let s_max = min(1.0, 1.0 - (1.0 - s_mean) * 0.25);
            if s > s_max {
                value = desaturate(input, s_max / s, yw);
            }
        }
        line[3 * x..3 * x + 3].copy_from_slice(&value);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rec709_luminance_weights() {
        // ITU-R BT.709's Y row (f32 arithmetic: within 1e-4).
        let yw = luminance_weights_f32(&Primaries::REC709);
        for (got, want) in yw.iter().zip(crate::colour::REC709_F32) {
            assert!((got - want).abs() < 1e-4, "{yw:?}");
        }
        assert!((yw.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn zero_chroma_gives_grey_luminance_exactly() {
        // RY = BY = 0 everywhere: every pixel is (Y, Y, Y) bit for bit (YCAtoRGBA's special
        // case), and nothing is desaturated.
        let (w, h) = (10usize, 6usize);
        let y: Vec<f32> = round_to_half((0..w * h).map(|i| (i as f32 * 0.37).sin().abs() * 8.0).collect());
        let zero = vec![0.0f32; (w / 2) * (h / 2)];
        let rgb = YcaPlanes { width: w, height: h, y: &y, ry: &zero, by: &zero }.to_rgb(&Primaries::REC709);
        for (i, px) in rgb.chunks_exact(3).enumerate() {
            assert_eq!(px, [y[i]; 3], "pixel {i}");
        }
    }

    #[test]
    fn constant_chroma_reconstructs_to_itself() {
        // The filters' taps sum to 1 (the horizontal and vertical half-band filters): a constant
        // chroma plane stays constant, so every pixel gets the same colour as the formula gives
        // for that chroma, within half rounding.
        let (w, h) = (32usize, 20usize);
        let y = vec![0.5f32; w * h];
        let (ry, by) = (vec![half(0.25); (w / 2) * (h / 2)], vec![half(-0.125); (w / 2) * (h / 2)]);
        let yw = luminance_weights_f32(&Primaries::REC709);
        let r = 1.25f32 * 0.5;
        let b = 0.875f32 * 0.5;
        let g = (0.5 - r * yw[0] - b * yw[2]) / yw[1];
        let rgb = YcaPlanes { width: w, height: h, y: &y, ry: &ry, by: &by }.to_rgb(&Primaries::REC709);
        for px in rgb.chunks_exact(3) {
            for (got, want) in px.iter().zip([r, g, b]) {
                assert!((got - want).abs() <= 2e-3 * want.abs(), "{px:?} vs {:?}", [r, g, b]);
            }
        }
    }
}
