//! One lat-long map from two photographs of a mirror ball taken from two viewpoints (commonly
//! 90 degrees apart): each ball's rim is a stretched, blurred view of the directions behind it,
//! and what one ball sees worst the other sees well.
//!
//! Each ball is the orthographic mirror ball of `geometry::azimuthal` (`DiscMap::mirror_ball`,
//! the mapping `MirrorBallToLatLong` uses), its camera frame `R_y(yaw) R_x(pitch)` applied to the
//! default one (looking along -Z). A direction d reflects off ball k at disc point (u, v), of
//! radius `r_k = sin(i_k)`, `i_k` the incidence angle of the camera's ray on the ball
//! (`cos(i_k) = n.c_k = sqrt((1 + d.c_k) / 2)`, `c_k` towards camera k): the larger `r_k`, the
//! nearer the rim. The crop holds the ball's disc, of diameter `ball_fraction` times the crop's
//! side, centred: disc point (u, v) is crop point `ball_fraction (u, v)`.
//!
//! - **Usable**: ball k sees d usably when `i_k <= 80` degrees (`r_k <= sin 80 deg = 0.985`: the
//!   last 20 degrees behind the ball are squeezed into the outer 1.5% of its radius) and the
//!   bilinear lookup at its crop point finds a tap whose centre lies within that radius (taps
//!   beyond it weigh 0 and the others are renormalised, as in `disc_to_latlong`).
//! - **Choice and seam**: d takes the ball with the smaller incidence, blended across the seam
//!   `r_a = r_b` with `w_a = smoothstep((r_b - r_a) / SEAM)`, `smoothstep(t) = s^2 (3 - 2 s)`,
//!   `s = clamp((t + 1) / 2, 0, 1)`, `SEAM = 0.1` in disc radius, and `w_b = 1 - w_a`; where only one
//!   ball is usable it alone gives d.
//! - **Camera**: each ball shows its own camera and photographer at its centre, in the
//!   directions within `camera_cone_deg` of `c_k` (angle `2 i_k`). There the other ball, if it
//!   sees d usably, takes over: with `kappa_k = 1 - smoothstep01((2 i_k - cone) / MARGIN)` (1
//!   inside the cone, 0 beyond it plus `MARGIN` = 5 degrees), `w_a` becomes `w_a (1 - kappa_a (1 -
//!   kappa_b))` where b is usable, then `w_a + (1 - w_a) kappa_b (1 - kappa_a)` where a is; where
//!   both cones overlap (two views a few degrees apart) the incidence rule stands. Views 90
//!   degrees apart see each other's camera directions at 45 degrees of incidence, well inside.
//! - **Mask**: 1 where neither ball sees d usably (the value there is 0); with two views more
//!   than a few degrees apart every direction is seen.
//!
//! Tests: two 256-pixel balls rendered from a smooth map (`latlong_to_disc`) merge back to it
//! within 1% relative everywhere, the blind spot behind each ball included, also with a dark
//! camera painted into each ball's centre (which a cone of 0 keeps in the map).

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::azimuthal::{pixel_uv, uv_pixel, DiscMap};
use crate::geometry::latlong;
use crate::geometry::rotation::Rotation;
use crate::values::Image;

/// The largest usable incidence angle on a ball, degrees.
pub const MAX_INCIDENCE_DEG: f64 = 80.0;
/// The half-width of the blend across the seam, in disc radius.
pub const SEAM: f64 = 0.1;
/// The width of the blend at the edge of a camera's cone, degrees.
pub const MARGIN_DEG: f64 = 5.0;

/// The mirror ball seen by a camera turned by `yaw` about +Y then `pitch` about +X, degrees
/// (roll 0), as `MirrorBallToLatLong(yaw, pitch)` reads it.
pub fn view_map(yaw: f64, pitch: f64) -> DiscMap {
    let m = Rotation::from_yaw_pitch_roll(yaw, pitch, 0.0).0;
    DiscMap::mirror_ball(m.x_axis, m.y_axis, m.z_axis)
}

/// One photograph: the square crop, its ball's mapping, and the fraction of the crop's side the
/// ball's diameter covers.
pub struct Ball<'a> {
    pub image: &'a Image,
    pub map: DiscMap,
    pub fraction: f64,
}

impl Ball<'_> {
    /// The disc radius of direction `d` and the bilinear value seen there (into `acc`), or the
    /// radius and `false` when the ball does not see it usably.
    fn look(&self, d: DVec3, r_max: f64, acc: &mut [f64]) -> (f64, bool) {
        let (u, v) = self.map.uv(d);
        let r = (u * u + v * v).sqrt();
        acc.fill(0.0);
        if r > r_max {
            return (r, false);
        }
        let img = self.image;
        let (w, h) = (img.width, img.height);
        let limit = self.fraction * r_max;
        let (fx, fy) = uv_pixel(self.fraction * u, self.fraction * v, w, h);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let mut wsum = 0.0;
        for (dx, dy, wt) in
            [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)]
        {
            let (sx, sy) = (x0 as isize + dx, y0 as isize + dy);
            if wt <= 0.0 || sx < 0 || sy < 0 || sx >= w as isize || sy >= h as isize {
                continue;
            }
            let (pu, pv) = pixel_uv(sx as usize, sy as usize, w, h);
            if pu * pu + pv * pv > limit * limit {
                continue;
            }
            for (a, &p) in acc.iter_mut().zip(img.pixel(sx as usize, sy as usize)) {
                *a += wt * p as f64;
            }
            wsum += wt;
        }
        if wsum == 0.0 {
            return (r, false);
        }
        acc.iter_mut().for_each(|a| *a /= wsum);
        (r, true)
    }
}

/// Ball a's weight where the balls see d at disc radii `ra` and `rb` (module documentation).
pub fn seam_weight(ra: f64, rb: f64) -> f64 {
    let s = (((rb - ra) / SEAM + 1.0) / 2.0).clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// How much of direction d, at disc radius `r` on a ball, is that ball's own camera: 1 within
/// `cone_deg` of the camera's direction (angle `2 asin r`), 0 beyond it plus [`MARGIN_DEG`].
pub fn camera_weight(r: f64, cone_deg: f64) -> f64 {
    if cone_deg <= 0.0 {
        return 0.0;
    }
    let angle = 2.0 * r.clamp(0.0, 1.0).asin().to_degrees();
    let s = ((angle - cone_deg) / MARGIN_DEG).clamp(0.0, 1.0);
    1.0 - s * s * (3.0 - 2.0 * s)
}

/// Ball a's weight from the incidence rule's `w` and each ball's camera weight (module
/// documentation), given which balls see d usably.
fn without_cameras(w: f64, kappa_a: f64, kappa_b: f64) -> f64 {
    let w = w * (1.0 - kappa_a * (1.0 - kappa_b));
    w + (1.0 - w) * kappa_b * (1.0 - kappa_a)
}

/// The merged map and where neither ball saw.
pub struct Merged {
    /// `width x height`, the channels (and names) of ball a's image; 0 where `unseen` is 1.
    pub image: Image,
    /// `width x height`, one channel: 1 where neither ball saw the texel's direction, else 0.
    pub unseen: Image,
}

/// The `width x height` lat-long map of balls `a` and `b` (of one channel count), each ball's
/// camera within `camera_cone_deg` replaced by the other ball's view (0: kept).
pub fn merge_balls(a: &Ball, b: &Ball, width: usize, height: usize, camera_cone_deg: f64) -> Merged {
    let c = a.image.channels;
    let r_max = MAX_INCIDENCE_DEG.to_radians().sin();
    let mut out = vec![0.0f32; width * height * c];
    let mut unseen = vec![0.0f32; width * height];
    out.par_chunks_mut(width * c).zip(unseen.par_chunks_mut(width)).enumerate().for_each(|(y, (row, mrow))| {
        let (mut va, mut vb) = (vec![0.0f64; c], vec![0.0f64; c]);
        for x in 0..width {
            let d = DVec3::from(latlong::texel_direction(x, y, width, height));
            let (ra, sa) = a.look(d, r_max, &mut va);
            let (rb, sb) = b.look(d, r_max, &mut vb);
            let wa = match (sa, sb) {
                (true, true) => without_cameras(
                    seam_weight(ra, rb),
                    camera_weight(ra, camera_cone_deg),
                    camera_weight(rb, camera_cone_deg),
                ),
                (true, false) => 1.0,
                (false, true) => 0.0,
                (false, false) => {
                    mrow[x] = 1.0;
                    continue;
                }
            };
            for k in 0..c {
                row[x * c + k] = (wa * va[k] + (1.0 - wa) * vb[k]) as f32;
            }
        }
    });
    Merged {
        image: Image::with_names(width, height, a.image.names.clone(), out),
        unseen: Image::from_vec(width, height, 1, unseen),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::resample::disc_image::latlong_to_disc;

    /// A smooth map with structure in every direction: 2 + d.y + 0.5 d.x - 0.3 d.z^2, per
    /// channel slightly different.
    fn env(w: usize, h: usize) -> Image {
        Image::from_fn_rgb(w, h, |x, y| {
            let d = DVec3::from(latlong::texel_direction(x, y, w, h));
            let v = 2.0 + d.y + 0.5 * d.x - 0.3 * d.z * d.z;
            [v as f32, (0.8 * v) as f32, (1.2 * v + 0.1 * d.z) as f32]
        })
    }

    /// The image `ball` centred in a larger square crop of side `side` (black around).
    fn pad(ball: &Image, side: usize) -> Image {
        let off = (side - ball.width) / 2;
        let mut out = Image::new(side, side, ball.channels);
        for y in 0..ball.height {
            for x in 0..ball.width {
                out.pixel_mut(x + off, y + off).copy_from_slice(ball.pixel(x, y));
            }
        }
        out
    }

    fn worst_relative(got: &Image, want: &Image) -> f64 {
        got.data.iter().zip(&want.data).map(|(g, w)| ((g - w) / w).abs() as f64).fold(0.0, f64::max)
    }

    #[test]
    fn two_rendered_balls_merge_back_to_the_map_blind_spots_included() {
        let truth = env(512, 256);
        let (ma, mb) = (view_map(0.0, 0.0), view_map(90.0, 0.0));
        let (ia, ib) = (latlong_to_disc(&truth, &ma, 256), latlong_to_disc(&truth, &mb, 256));
        let merged = merge_balls(
            &Ball { image: &ia, map: ma, fraction: 1.0 },
            &Ball { image: &ib, map: mb, fraction: 1.0 },
            128,
            64,
            0.0,
        );
        assert!(merged.unseen.data.iter().all(|&m| m == 0.0), "every direction is seen by one ball");
        let want = env(128, 64);
        let worst = worst_relative(&merged.image, &want);
        eprintln!("two balls: worst relative error {worst:.2e}");
        assert!(worst < 1e-2, "{worst}");
        // Ball a's blind spot, straight behind it (its camera looks along -Z: -c = -Z), comes from
        // ball b; ball a alone sees nothing there.
        let (x, y) = latlong::texel_of_direction([0.0, 0.0, -1.0], 128, 64);
        let alone = merge_balls(
            &Ball { image: &ia, map: ma, fraction: 1.0 },
            &Ball { image: &ia, map: ma, fraction: 1.0 },
            128,
            64,
            0.0,
        );
        assert_eq!(alone.unseen.data[y * 128 + x], 1.0, "one ball does not see behind itself");
        assert_eq!(alone.image.pixel(x, y), &[0.0, 0.0, 0.0]);
        let got = merged.image.pixel(x, y)[0];
        assert!((got / want.pixel(x, y)[0] - 1.0).abs() < 1e-2, "{got}");
    }

    #[test]
    fn a_ball_smaller_than_its_crop_reads_the_same() {
        let truth = env(512, 256);
        let (ma, mb) = (view_map(30.0, 10.0), view_map(120.0, -5.0));
        let (ia, ib) = (latlong_to_disc(&truth, &ma, 200), latlong_to_disc(&truth, &mb, 200));
        let tight = merge_balls(
            &Ball { image: &ia, map: ma, fraction: 1.0 },
            &Ball { image: &ib, map: mb, fraction: 1.0 },
            96,
            48,
            20.0,
        );
        let (pa, pb) = (pad(&ia, 250), pad(&ib, 250));
        let loose = merge_balls(
            &Ball { image: &pa, map: ma, fraction: 0.8 },
            &Ball { image: &pb, map: mb, fraction: 0.8 },
            96,
            48,
            20.0,
        );
        assert_eq!(tight.unseen.data, loose.unseen.data);
        let diff = worst_relative(&loose.image, &tight.image);
        assert!(diff < 1e-5, "{diff}");
    }

    /// Each ball with a dark camera at its centre (directions within 8 degrees of its camera):
    /// the default cone of 20 degrees takes those directions from the other ball, and the map
    /// is the truth within 1% again; a cone of 0 keeps the camera (the map dark there).
    #[test]
    fn each_camera_is_replaced_by_the_other_balls_view() {
        let truth = env(512, 256);
        let (ma, mb) = (view_map(0.0, 0.0), view_map(90.0, 0.0));
        let paint = |img: &mut Image| {
            let (w, h) = (img.width, img.height);
            for y in 0..h {
                for x in 0..w {
                    let (u, v) = pixel_uv(x, y, w, h);
                    if (u * u + v * v).sqrt() < 4f64.to_radians().sin() {
                        img.pixel_mut(x, y).fill(0.0);
                    }
                }
            }
        };
        let (mut ia, mut ib) = (latlong_to_disc(&truth, &ma, 256), latlong_to_disc(&truth, &mb, 256));
        paint(&mut ia);
        paint(&mut ib);
        let merge = |cone: f64| {
            merge_balls(
                &Ball { image: &ia, map: ma, fraction: 1.0 },
                &Ball { image: &ib, map: mb, fraction: 1.0 },
                128,
                64,
                cone,
            )
        };
        let want = env(128, 64);
        let worst = worst_relative(&merge(20.0).image, &want);
        eprintln!("two balls with their cameras: worst relative error {worst:.2e}");
        assert!(worst < 1e-2, "{worst}");
        // Camera a looks along -Z, so it is seen towards +Z.
        let (x, y) = latlong::texel_of_direction([0.0, 0.0, 1.0], 128, 64);
        let kept = merge(0.0).image.pixel(x, y)[0];
        assert!(kept < 0.1 * want.pixel(x, y)[0], "a cone of 0 keeps the camera: {kept}");
    }

    #[test]
    fn the_camera_weight_fades_at_the_cone() {
        let r = |angle_deg: f64| (angle_deg / 2.0).to_radians().sin();
        assert_eq!(camera_weight(r(10.0), 20.0), 1.0);
        assert_eq!(camera_weight(r(25.5), 20.0), 0.0);
        assert!((camera_weight(r(22.5), 20.0) - 0.5).abs() < 1e-9);
        assert_eq!(camera_weight(0.0, 0.0), 0.0);
        // Both cameras or neither: the incidence rule stands; one: the other ball.
        assert_eq!(without_cameras(0.3, 0.0, 0.0), 0.3);
        assert_eq!(without_cameras(0.3, 1.0, 1.0), 0.3);
        assert_eq!(without_cameras(1.0, 1.0, 0.0), 0.0);
        assert_eq!(without_cameras(0.0, 0.0, 1.0), 1.0);
    }

    #[test]
    fn the_seam_weight_is_smooth_and_symmetric() {
        assert_eq!(seam_weight(0.5, 0.5), 0.5);
        assert_eq!(seam_weight(0.2, 0.5), 1.0);
        assert_eq!(seam_weight(0.5, 0.2), 0.0);
        for (ra, rb) in [(0.3, 0.35), (0.6, 0.52), (0.1, 0.13)] {
            assert!((seam_weight(ra, rb) + seam_weight(rb, ra) - 1.0).abs() < 1e-15);
        }
    }
}
