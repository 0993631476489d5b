//! Disc images (the azimuthal layouts of `geometry::azimuthal`: angular probe, sky angular,
//! mirror ball) to and from lat-long maps.
//!
//! - **Disc to lat-long** ([`disc_to_latlong`]): each lat-long texel is a bilinear lookup in the
//!   disc image at its centre direction's disc point. Taps whose pixel centres lie outside the
//!   usable radius `limit` (1: the whole disc; a mirror ball's `ball_fraction`) weigh 0 and the
//!   others are renormalised, so nothing from outside the usable disc leaks in. The mask is 1
//!   where the centre direction's disc radius is at most `limit` and some tap was usable, 0
//!   elsewhere (the value there is 0).
//! - **Lat-long to disc** ([`latlong_to_disc`]): each pixel whose centre lies in the disc gets
//!   the solid-angle mean of the map over its footprint, by the cut cells of
//!   `maths::resample::cut_cells` in (u, v) (the subdivision of `maths::resample::layouts`, whose
//!   cells over a few source texels are cut along the texel boundaries; cells
//!   across the rim take the midpoint rule), a leaf weighing `density(centre) * area` (`dOmega / dA`: exact
//!   for the ball, whose density is the constant 4; the midpoint rule for the equidistant
//!   layouts), or 0 when its centre is outside the disc. A pixel is cut down to the source's
//!   texels, the depth set by its own angular extent (`DiscMap::pixel_extent`: a mirror ball's
//!   rim pixels span tens of degrees radially), unless a larger cell's cut holds (`cut_cells`:
//!   the source's angles planar over it to the tolerance). Pixels whose centre is outside the disc
//!   are 0. A constant map stays constant to f32 rounding, and `sum value * density * area`
//!   over the disc equals the map's integral up to the pixelated rim (tests: 1e-3 on the sky).

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::azimuthal::{pixel_uv, uv_pixel, DiscMap};
use crate::geometry::latlong;
use crate::maths::resample::cut_cells::Cells;
use crate::maths::resample::layouts::{per_channel_triples, Footprint, LatLongSource, Limits};
use crate::values::Image;

/// A lat-long map looked up in a disc image, and where it was seen.
pub struct Unwrapped {
    /// W x H, the disc image's channels and names; 0 where `mask` is 0.
    pub image: Image,
    /// W x H, one channel: 1 where the texel was seen by the usable disc, else 0.
    pub mask: Image,
}

/// The `width x height` lat-long map seen in disc image `img` (any size; the disc is inscribed
/// in it, an ellipse if it is not square), pixels beyond radius `limit` unused.
pub fn disc_to_latlong(img: &Image, map: &DiscMap, limit: f64, width: usize, height: usize) -> Unwrapped {
    let c = img.channels;
    let (pw, ph) = (img.width, img.height);
    let limit2 = limit * limit;
    let usable = |x: isize, y: isize| -> bool {
        if x < 0 || y < 0 || x >= pw as isize || y >= ph as isize {
            return false;
        }
        let (u, v) = pixel_uv(x as usize, y as usize, pw, ph);
        u * u + v * v <= limit2
    };
    let mut out = vec![0.0f32; width * height * c];
    let mut mask = vec![0.0f32; width * height];
    out.par_chunks_mut(width * c).zip(mask.par_chunks_mut(width)).enumerate().for_each(|(y, (row, mrow))| {
        let mut acc = vec![0.0f64; c];
        for x in 0..width {
            let (u, v) = map.uv(DVec3::from(latlong::texel_direction(x, y, width, height)));
            if u * u + v * v > limit2 {
                continue;
            }
            let (fx, fy) = uv_pixel(u, v, pw, ph);
            let (x0, y0) = (fx.floor(), fy.floor());
            let (tx, ty) = (fx - x0, fy - y0);
            acc.fill(0.0);
            let mut wsum = 0.0;
            for (dx, dy, w) in
                [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)]
            {
                let (sx, sy) = (x0 as isize + dx, y0 as isize + dy);
                if w > 0.0 && usable(sx, sy) {
                    let p = img.pixel(sx as usize, sy as usize);
                    for k in 0..c {
                        acc[k] += w * p[k] as f64;
                    }
                    wsum += w;
                }
            }
            if wsum > 0.0 {
                for k in 0..c {
                    row[x * c + k] = (acc[k] / wsum) as f32;
                }
                mrow[x] = 1.0;
            }
        }
    });
    Unwrapped {
        image: Image::with_names(width, height, img.names.clone(), out),
        mask: Image::from_vec(width, height, 1, mask),
    }
}

/// A disc pixel's footprint: p = u, q = v; a leaf weighs `density * area` when its centre is in
/// the disc, 0 otherwise.
struct DiscDomain<'a>(&'a DiscMap);

impl Footprint for DiscDomain<'_> {
    fn dir(&self, p: f64, q: f64) -> DVec3 {
        self.0.direction_clamped(p, q)
    }
    fn solid_angle(&self, p0: f64, p1: f64, q0: f64, q1: f64) -> f64 {
        let (pm, qm) = (0.5 * (p0 + p1), 0.5 * (q0 + q1));
        if pm * pm + qm * qm > 1.0 {
            0.0
        } else {
            self.0.density(pm, qm) * (p1 - p0) * (q1 - q0)
        }
    }
    fn whole(&self, [p0, p1, q0, q1]: [f64; 4]) -> bool {
        // The disc is convex: a cell whose corners are in it is in it.
        [(p0, q0), (p1, q0), (p0, q1), (p1, q1)].iter().all(|(p, q)| p * p + q * q <= 1.0)
    }
}

/// The N x N RGB disc image whose pixels average `src` over their footprints (module docs).
pub fn to_disc(src: &LatLongSource, map: &DiscMap, n: usize) -> Image {
    let mut out = Image::new(n, n, 3);
    let d = 2.0 / n as f64;
    let domain = DiscDomain(map);
    let cells = Cells::new(src, &domain, DMat3::IDENTITY);
    out.data.par_chunks_mut(3 * n).enumerate().for_each(|(y, row)| {
        for x in 0..n {
            let (u, v) = pixel_uv(x, y, n, n);
            if u * u + v * v > 1.0 {
                continue;
            }
            let lim = Limits::new(src, map.pixel_extent(u, v, n));
            let r = [d * x as f64 - 1.0, d * (x + 1) as f64 - 1.0, 1.0 - d * (y + 1) as f64, 1.0 - d * y as f64];
            row[3 * x..3 * x + 3].copy_from_slice(&cells.average(r, &lim));
        }
    });
    out
}

/// The N x N disc image of a lat-long map, every channel (names kept).
pub fn latlong_to_disc(env: &Image, map: &DiscMap, n: usize) -> Image {
    per_channel_triples(env, n, n, |src| to_disc(src, map, n))
}

/// `sum value * density * area` over the pixels of an N x N disc image whose centres are in the
/// disc: its integral over the directions it covers, per channel (the first three).
pub fn disc_integral(img: &Image, map: &DiscMap) -> [f64; 3] {
    let n = img.width;
    let area = (2.0 / n as f64) * (2.0 / img.height as f64);
    let mut sum = [0.0; 3];
    for y in 0..img.height {
        for x in 0..n {
            let (u, v) = pixel_uv(x, y, n, img.height);
            if u * u + v * v <= 1.0 {
                let w = map.density(u, v) * area;
                for (s, p) in sum.iter_mut().zip(img.rgb(x, y)) {
                    *s += p as f64 * w;
                }
            }
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::builtin::builtin;
    use crate::maths::resample::layouts::latlong_integral;

    fn ball() -> DiscMap {
        DiscMap::mirror_ball(DVec3::X, DVec3::Y, DVec3::Z)
    }

    #[test]
    fn a_constant_map_stays_constant_inside_the_disc_and_zero_outside() {
        let env = builtin("constant").unwrap();
        for map in [DiscMap::ANGULAR, DiscMap::SKY_ANGULAR, ball()] {
            let disc = latlong_to_disc(&env, &map, 33);
            for y in 0..33 {
                for x in 0..33 {
                    let (u, v) = pixel_uv(x, y, 33, 33);
                    let want = if u * u + v * v <= 1.0 { 1.0 } else { 0.0 };
                    assert!((disc.pixel(x, y)[0] - want).abs() < 1e-6, "{map:?} ({x}, {y}): {:?}", disc.pixel(x, y));
                }
            }
        }
    }

    #[test]
    fn the_integral_is_kept() {
        let env = builtin("sky").unwrap();
        let want = latlong_integral(&env);
        for map in [DiscMap::ANGULAR, ball()] {
            let got = disc_integral(&latlong_to_disc(&env, &map, 256), &map);
            let rel = (0..3).map(|k| ((got[k] - want[k]) / want[k]).abs()).fold(0.0, f64::max);
            assert!(rel < 1e-3, "{map:?}: {got:?} vs {want:?}: {rel:e}");
        }
    }

    #[test]
    fn nothing_leaks_from_beyond_the_limit() {
        // 1 inside radius 0.5, 1000 beyond: with limit 0.5 no 1000 reaches the map, and the mask
        // is 0 exactly where the direction's radius exceeds 0.5.
        let n = 64;
        let mut img = Image::new(n, n, 1);
        for y in 0..n {
            for x in 0..n {
                let (u, v) = pixel_uv(x, y, n, n);
                img.data[y * n + x] = if u * u + v * v <= 0.25 { 1.0 } else { 1000.0 };
            }
        }
        let map = ball();
        let out = disc_to_latlong(&img, &map, 0.5, 64, 32);
        for y in 0..32 {
            for x in 0..64 {
                let (u, v) = map.uv(DVec3::from(latlong::texel_direction(x, y, 64, 32)));
                let m = out.mask.data[y * 64 + x];
                let val = out.image.data[y * 64 + x];
                assert!(val <= 1.0, "({x}, {y}) leaked {val}");
                if u * u + v * v > 0.25 {
                    assert_eq!((m, val), (0.0, 0.0));
                } else {
                    assert!(m == 1.0 || u * u + v * v > 0.45 * 0.45, "({x}, {y}) unseen at r^2 {}", u * u + v * v);
                    assert!(m == 0.0 || val == 1.0, "({x}, {y}): {val}");
                }
            }
        }
    }

    /// The ball of a texel-noise map against a brute-force footprint mean (n x n cells a pixel,
    /// each weighing `density * area` when its centre is in the disc) on the pixels away from the
    /// rim: the cut cells agree with it as closely as the midpoint subdivision they replace.
    #[test]
    fn agrees_with_a_brute_force_footprint_mean() {
        use crate::maths::resample::layouts::{average, LatLongSource, SphereSource};
        let (w, h) = (48, 24);
        let data = (0..w * h * 3).map(|i| 0.5 + ((i * 7919 + i / 3 * 104729) % 1009) as f32 / 1009.0).collect();
        let env = Image::from_vec(w, h, 3, data);
        let src = LatLongSource::new(&env);
        let map = DiscMap::mirror_ball(DVec3::X, DVec3::Y, DVec3::Z);
        let n = 24;
        let new = to_disc(&src, &map, n);
        let d = 2.0 / n as f64;
        let (mut new_err, mut old_err, mut count) = (0.0f64, 0.0f64, 0.0);
        for y in 0..n {
            for x in 0..n {
                let (u, v) = pixel_uv(x, y, n, n);
                if u * u + v * v > 0.8 {
                    continue;
                }
                let r = [d * x as f64 - 1.0, d * (x + 1) as f64 - 1.0, 1.0 - d * (y + 1) as f64, 1.0 - d * y as f64];
                let old = average(&src, &DiscDomain(&map), r, &Limits::new(&src, map.pixel_extent(u, v, n)));
                let m = 256;
                let mut acc = [0.0f64; 3];
                for j in 0..m {
                    for i in 0..m {
                        let (p, q) = (r[0] + d * (i as f64 + 0.5) / m as f64, r[2] + d * (j as f64 + 0.5) / m as f64);
                        let t = src.texel_of(map.direction_clamped(p, q));
                        let v = src.rgb(t);
                        for k in 0..3 {
                            acc[k] += v[k] / (m * m) as f64;
                        }
                    }
                }
                let got = new.pixel(x, y);
                for k in 0..3 {
                    new_err = new_err.max((got[k] as f64 - acc[k]).abs() / acc[k]);
                    old_err = old_err.max((old[k] as f64 - acc[k]).abs() / acc[k]);
                }
                count += 1.0;
            }
        }
        assert!(count > 300.0);
        eprintln!("ball: cut cells worst {new_err:.2e}, midpoint worst {old_err:.2e}");
        // The brute force's own error (1/256 of a pixel per cell on the boundaries) is about 1e-4.
        assert!(new_err < 2e-3 && new_err < 1.5 * old_err + 2e-4, "cut cells {new_err:e}, midpoint {old_err:e}");
    }
}
