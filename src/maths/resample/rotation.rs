//! Rotating spherical maps: a rotated view of any [`SphereSource`] and a rotated lat-long map, by
//! the footprint-mean resampling of [`crate::maths::resample::cut_cells`]. The rotations and their
//! angle conventions are [`crate::geometry::rotation`].
//!
//! Rotating a map by R moves the content seen in direction `v` to direction `R v`:
//! `out(d) = in(R^T d)`. On a lat-long map, `R_y(a)` maps azimuth phi to phi - a, so a yaw of
//! `k * 360 / W` degrees is a roll of the columns by k: `out[x] = in[(x + k) mod W]`.

use glam::{DMat3, DVec3};

use crate::geometry::rotation::Rotation;
use crate::maths::resample::cut_cells::rotated_latlong;
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

/// A lat-long map rotated by `r`, every channel alike, keeping its size and channel names.
///
/// A whole-column yaw is an exact roll of the columns (the same bits). Any other rotation gives
/// each output texel the solid-angle mean of the rotated map over its footprint
/// (`resample::cut_cells`, each cell's error below 1e-9 of the map's magnitude), which keeps the
/// sphere integral (tested: 1e-6 relative) and agrees with a brute-force footprint mean to the
/// brute force's own error.
pub fn rotate_latlong(img: &Image, r: Rotation) -> Image {
    let (w, h) = (img.width, img.height);
    if let Some(k) = r.whole_column_shift(w) {
        let mut out = img.clone();
        roll_columns(&mut out, k);
        return out;
    }
    let inverse = r.0.transpose();
    per_channel_triples(img, w, h, |src| rotated_latlong(src, inverse, 1e-9, 12))
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
