//! Rotating spherical maps: a rotated view of any [`SphereSource`] and a rotated lat-long map, by
//! the footprint-mean resampling of [`crate::maths::resample::cut_cells`]. The rotations and their
//! angle conventions are [`crate::geometry::rotation`].
//!
//! Rotating a map by R moves the content seen in direction `v` to direction `R v`:
//! `out(d) = in(R^T d)`. On a lat-long map, `R_y(a)` maps azimuth phi to phi - a, so a yaw of
//! `k * 360 / W` degrees is a roll of the columns by k: `out[x] = in[(x + k) mod W]`, and a yaw
//! of `s = k + f` columns (`0 <= f < 1`) is exactly the blend of two columns,
//! `out[x] = (1 - f) in[x + k] + f in[x + k + 1]` ([`yaw_columns`]).

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::rotation::Rotation;
use crate::maths::resample::cut_cells::{rotated_latlong, ROTATION_TOLERANCE};
use crate::maths::resample::layouts::{per_channel_triples, SphereSource};
use crate::values::Image;

/// A spherical map seen rotated: `texel_of(d)` is the source's texel at `R^T d`.
pub struct Rotated<'a, S: SphereSource> {
    pub source: &'a S,
    /// `R^T`, the inverse rotation, applied to every output direction.
    inverse: DMat3,
}

impl<'a, S: SphereSource> Rotated<'a, S> {
    pub fn new(source: &'a S, rotation: Rotation) -> Self {
        Rotated { source, inverse: rotation.0.transpose() }
    }
}

impl<S: SphereSource> SphereSource for Rotated<'_, S> {
    fn texel_of(&self, d: DVec3) -> usize {
        self.source.texel_of(self.inverse * d)
    }
    fn rgb(&self, t: usize) -> [f64; 3] {
        self.source.rgb(t)
    }
    fn texel_angle(&self) -> f64 {
        self.source.texel_angle()
    }
    fn magnitude(&self) -> f64 {
        self.source.magnitude()
    }
}

/// Rolls every row of a lat-long image left by `k` columns, in place: the exact rotation by a
/// yaw of `k` whole columns (`Rotation::whole_column_shift`), column x taking column x + k.
pub fn roll_columns(img: &mut Image, k: usize) {
    let row_len = img.width * img.channels;
    for row in img.data.chunks_exact_mut(row_len.max(1)) {
        row.rotate_left(k * img.channels);
    }
}

/// A lat-long map turned by a yaw of `columns` column widths (`yaw * W / 360`, any real; taken
/// mod W), every channel: `out[x] = (1 - f) in[x + k] + f in[x + k + 1]` (columns mod W), where
/// `k + f = columns mod W`, `0 <= f < 1`, computed in f64 and rounded once to f32.
///
/// This is the footprint mean exactly, not an interpolation: a yaw keeps every row and moves the
/// azimuth by whole and fractional column widths, so output texel x's footprint is its row's
/// azimuth range `[x + k + f, x + k + 1 + f)` (in columns), which covers `1 - f` of source
/// column x + k and `f` of x + k + 1, and the solid-angle density (`sin theta`) does not change
/// along a row. Each row's sum, hence the sphere integral, is kept to f32 rounding (tests: the
/// cut cells' result to 1e-6 away from the pole rows, the integral to 1e-6).
pub fn yaw_columns(img: &Image, columns: f64) -> Image {
    let (w, c) = (img.width, img.channels);
    let mut out = Image::with_names(w, img.height, img.names.clone(), vec![0.0; img.data.len()]);
    if w == 0 || c == 0 {
        return out;
    }
    let s = columns.rem_euclid(w as f64);
    let k = s.floor();
    let f = s - k;
    let k = k as usize % w;
    out.data.par_chunks_mut(w * c).zip(img.data.par_chunks(w * c)).for_each(|(row, src)| {
        for x in 0..w {
            let (a, b) = ((x + k) % w * c, (x + k + 1) % w * c);
            for ch in 0..c {
                row[x * c + ch] = ((1.0 - f) * src[a + ch] as f64 + f * src[b + ch] as f64) as f32;
            }
        }
    });
    out
}

/// A lat-long map rotated by `r`, every channel alike, keeping its size and channel names.
///
/// A whole-column yaw is an exact roll of the columns (the same bits); any other pure yaw the
/// exact blend of two columns ([`yaw_columns`]). Any other rotation gives
/// each output texel the solid-angle mean of the rotated map over its footprint
/// (`resample::cut_cells`, each cell's error bound below `ROTATION_TOLERANCE`, 4e-9, of the map's
/// magnitude), which keeps the
/// sphere integral (tested: 1e-6 relative) and agrees with a brute-force footprint mean to the
/// brute force's own error.
pub fn rotate_latlong(img: &Image, r: Rotation) -> Image {
    let (w, h) = (img.width, img.height);
    if let Some(k) = r.whole_column_shift(w) {
        let mut out = img.clone();
        roll_columns(&mut out, k);
        return out;
    }
    if let Some(yaw) = r.pure_yaw_degrees() {
        return yaw_columns(img, yaw * w as f64 / 360.0);
    }
    let inverse = r.0.transpose();
    per_channel_triples(img, w, h, |src| rotated_latlong(src, inverse, ROTATION_TOLERANCE, 12))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;

    fn test_map(w: usize, h: usize, c: usize) -> Image {
        let data = (0..w * h * c).map(|i| ((i * 7919) % 101) as f32 * 0.01 + (i % c) as f32).collect();
        Image::from_vec(w, h, c, data)
    }

    fn integral(img: &Image) -> Vec<f64> {
        let (w, h, c) = (img.width, img.height, img.channels);
        let mut sum = vec![0.0; c];
        for y in 0..h {
            for x in 0..w {
                for (k, s) in sum.iter_mut().enumerate() {
                    *s += img.pixel(x, y)[k] as f64 * latlong::texel_solid_angle(y, w, h);
                }
            }
        }
        sum
    }

    #[test]
    fn a_whole_column_yaw_rolls_the_columns_exactly() {
        let img = test_map(32, 16, 4);
        let out = rotate_latlong(&img, Rotation::from_yaw_pitch_roll(45.0, 0.0, 0.0));
        for y in 0..16 {
            for x in 0..32 {
                assert_eq!(out.pixel(x, y), img.pixel((x + 4) % 32, y));
            }
        }
        // The resampled path agrees with the roll on a map that is constant per texel.
        let general = rotate_latlong(&img, Rotation::from_yaw_pitch_roll(45.0 + 1e-7, 0.0, 0.0));
        let worst = general.data.iter().zip(&out.data).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
    }

    /// The blend against the cut cells' footprint means of the same yaw (`cut_cells`), on texel
    /// noise: the same f32 values away from the pole rows (measured: 0). In the pole rows the cut
    /// cells are off, not the blend: their cells touching the pole have a corner whose source
    /// azimuth is undefined (`atan2(0, 0)`), so the azimuth plane is wrong there and its large
    /// bend splits them only until `spread * Omega * bend` meets the tolerance, 1e-9 of the map's
    /// magnitude, a large share of a pole texel's small solid angle. Measured when those thin
    /// cells were still split into four: 6.1e-5 here, falling with the tolerance (1.5e-5 at 1e-10,
    /// 2.6e-6 at 1e-11, 6.5e-7 at 1e-12; no change from depth 12 to 16), and 1.7e-4 on
    /// `cut_cells`' noise map whose sun raises the magnitude (4.9e-6 with them halved across).
    #[test]
    fn a_fractional_yaw_blends_two_columns_as_the_cut_cells_integrate_them() {
        use crate::maths::resample::cut_cells::rotated_latlong;
        use crate::maths::resample::layouts::LatLongSource;
        let (w, h) = (48, 24);
        let data = (0..w * h * 3).map(|i| 0.5 + ((i * 7919 + i / 3 * 104729) % 1009) as f32 / 1009.0).collect();
        let img = Image::from_vec(w, h, 3, data);
        // 7.5 degrees a column: 2.04 columns.
        let r = Rotation::from_yaw_pitch_roll(15.3, 0.0, 0.0);
        let fast = rotate_latlong(&img, r);
        let cut = rotated_latlong(&LatLongSource::new(&img), r.0.transpose(), 1e-9, 12);
        let (mut inside, mut poles) = (0.0f64, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (img.pixel((x + 2) % w, y), img.pixel((x + 3) % w, y));
                for k in 0..3 {
                    let want = 0.96 * a[k] as f64 + 0.04 * b[k] as f64;
                    assert!((fast.pixel(x, y)[k] as f64 - want).abs() <= 1e-7 * want, "({x}, {y})");
                    let e = ((fast.pixel(x, y)[k] - cut.pixel(x, y)[k]) / cut.pixel(x, y)[k]).abs() as f64;
                    if y == 0 || y == h - 1 {
                        poles = poles.max(e);
                    } else {
                        inside = inside.max(e);
                    }
                }
            }
        }
        eprintln!("blend against cut cells: rows 1 to H - 2 {inside:e}, pole rows {poles:e}");
        assert!(inside <= 1e-6, "the blend and the cut cells away from the poles: {inside:e}");
        assert!(poles <= 1e-5, "the blend and the cut cells in the pole rows: {poles:e}");
        // Any yaw, negative or past a turn, keeps each channel's integral.
        let img = test_map(96, 48, 4);
        let want = integral(&img);
        for yaw in [-12.5, 0.1, 361.3, -725.0] {
            let out = rotate_latlong(&img, Rotation::from_yaw_pitch_roll(yaw, 0.0, 0.0));
            assert_eq!(out.names, img.names);
            for (a, b) in integral(&out).iter().zip(&want) {
                assert!(((a - b) / b).abs() < 1e-6, "yaw {yaw}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn rotations_keep_the_integral_and_invert() {
        let img = test_map(64, 32, 3);
        let r = Rotation::from_yaw_pitch_roll(33.0, 21.0, -12.0);
        let out = rotate_latlong(&img, r);
        for (a, b) in integral(&out).iter().zip(integral(&img)) {
            assert!(((a - b) / b).abs() < 1e-4, "{a} vs {b}");
        }
        let back = rotate_latlong(&out, r.inverse());
        // Two resamplings blur a texel-noise map; the mean error stays a fraction of its range.
        let mean_err: f64 =
            back.data.iter().zip(&img.data).map(|(a, b)| (a - b).abs() as f64).sum::<f64>() / img.data.len() as f64;
        assert!(mean_err < 0.25, "{mean_err}");
    }

    #[test]
    fn a_point_light_moves_where_the_rotation_sends_it() {
        let (w, h) = (128, 64);
        let mut img = Image::new(w, h, 1);
        let (x0, y0) = (96, 20);
        img.data[y0 * w + x0] = 1.0;
        let r = Rotation::from_yaw_pitch_roll(17.0, 25.0, 5.0);
        let out = rotate_latlong(&img, r);
        let (mut best, mut at) = (0.0, (0, 0));
        for y in 0..h {
            for x in 0..w {
                if out.data[y * w + x] > best {
                    best = out.data[y * w + x];
                    at = (x, y);
                }
            }
        }
        let want = r.apply(DVec3::from(latlong::texel_direction(x0, y0, w, h)));
        let got = DVec3::from(latlong::texel_direction(at.0, at.1, w, h));
        assert!(want.angle_between(got) < 2.0 * std::f64::consts::PI / w as f64, "{want} vs {got}");
    }
}
