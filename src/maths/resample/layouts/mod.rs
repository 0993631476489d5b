//! Energy-preserving resampling between spherical layouts: lat-long, cube map and equal-area
//! octahedral.
//!
//! The source is read as piecewise constant (each texel's radiance over its whole footprint).
//! Each output texel gets the solid-angle-weighted average of the source over its footprint:
//!
//! ```text
//! out(T) = (1 / Omega(T)) * integral over T of L_src(w) dw
//! ```
//!
//! computed by adaptive subdivision of the output texel in its own parameters (face coordinates
//! for a cube face, (phi, theta) for a lat-long texel, the unit square for an octahedral image),
//! each cell weighted by its *exact* solid angle (`geometry::cubemap::rect_solid_angle`;
//! `dphi (cos theta0 - cos theta1)`; `4 pi dA`). A cell is split:
//!
//! - always, while it is larger than a source texel (so no source texel is skipped);
//! - when its four corners and centre do not fall in one source texel, and those texels differ:
//!   once more (down to half a source texel) if their largest channel difference `spread`
//!   exceeds 1% of their largest value, and further while `spread * Omega(cell) > tol`,
//!   `tol = 1e-7` times the source's integral of its largest channel, down to 1/256 of a source
//!   texel.
//!
//! A leaf takes the source texel at its centre. The weights of an output texel's cells sum to
//! its solid angle, so a constant map stays exactly constant (to rounding), and the sphere
//! integral `sum_T out(T) Omega(T)` equals the source's to the quadrature error of the leaves on
//! source texel boundaries, each below `tol` unless the depth limit stopped it: the tests check
//! 1e-3 relative on the built-in sky, whose 2-degree sun (a few texels) carries 97% of the
//! energy (measured: 1.5e-5 to a 64 or 256 cube; 9e-4 for the worst round trip of docs/src/benchmarks/ibl.md,
//! the park's 69,120 sun from a 256 cube back to 1024x512). The lat-long
//! source's integral is its midpoint sum (`latlong::texel_solid_angle`), which differs from the
//! exact integral of the piecewise-constant map by O(1/H^2) relative (3e-6 at H = 256).
//!
//! Seams: a cube texel's value depends only on its footprint on the sphere, so texels on both
//! sides of a face edge are averages over adjacent footprints, exactly as two neighbours inside a
//! face are (tested: on a smooth map the largest difference across an edge is within 1.5 times
//! the largest between neighbours inside a face).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{cubemap as cube, latlong, octahedral};
use crate::values::{Cubemap, Image};

/// A spherical map read as piecewise constant.
pub trait SphereSource: Sync {
    /// The flat index of the texel containing `d`.
    fn texel_of(&self, d: DVec3) -> usize;
    /// The RGB value of texel `t`.
    fn rgb(&self, t: usize) -> [f64; 3];
    /// The angular size (radians) of a small texel side: output cells are split at least down to
    /// it, so that no source texel falls between a cell's corners and centre unseen.
    fn texel_angle(&self) -> f64;
    /// The integral over the sphere of each texel's largest absolute channel (sets the tolerance).
    fn magnitude(&self) -> f64;
}

/// Three channels of a lat-long image, read as piecewise constant: by default R, G, B (a
/// one- or two-channel image reads its first channel as grey, as `Image::rgb` does), or any
/// three channels named by index ([`LatLongSource::channels`]: a resampler of RGB values
/// serves images of any channel count, three at a time).
pub struct LatLongSource<'a> {
    img: &'a Image,
    pick: [usize; 3],
    magnitude: f64,
}

impl<'a> LatLongSource<'a> {
    pub fn new(img: &'a Image) -> Self {
        let pick = if img.channels < 3 { [0; 3] } else { [0, 1, 2] };
        LatLongSource::channels(img, pick)
    }

    /// The channels `pick` of `img` (each index below `img.channels`).
    pub fn channels(img: &'a Image, pick: [usize; 3]) -> Self {
        let (w, h) = (img.width, img.height);
        let mut src = LatLongSource { img, pick, magnitude: 0.0 };
        src.magnitude = (0..h)
            .map(|y| {
                let row: f64 = (0..w).map(|x| max_abs(src.texel(x, y))).sum();
                row * latlong::texel_solid_angle(y, w, h)
            })
            .sum();
        src
    }

    #[inline]
    fn texel(&self, x: usize, y: usize) -> [f32; 3] {
        // An RGB image's own three channels (the usual case) without the pick's indirection: the
        // cut cells' texel reads showed in profiles.
        if self.img.channels == 3 && self.pick == [0, 1, 2] {
            let i = (y * self.img.width + x) * 3;
            if let Some(&[r, g, b]) = self.img.data.get(i..i + 3) {
                return [r, g, b];
            }
        }
        let px = self.img.pixel(x, y);
        self.pick.map(|k| px[k])
    }

    /// The three picked channels of texel (x, y).
    #[inline]
    pub(crate) fn texel_rgb(&self, x: usize, y: usize) -> [f32; 3] {
        self.texel(x, y)
    }

    /// The map's (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.img.width, self.img.height)
    }
}

impl SphereSource for LatLongSource<'_> {
    fn texel_of(&self, d: DVec3) -> usize {
        let (x, y) = latlong::texel_of_direction(d.into(), self.img.width, self.img.height);
        y * self.img.width + x
    }
    fn rgb(&self, t: usize) -> [f64; 3] {
        self.texel(t % self.img.width, t / self.img.width).map(f64::from)
    }
    fn texel_angle(&self) -> f64 {
        (PI / self.img.height as f64).min(2.0 * PI / self.img.width as f64)
    }
    fn magnitude(&self) -> f64 {
        self.magnitude
    }
}

/// A cube map.
pub struct CubeSource<'a> {
    cube: &'a Cubemap,
    magnitude: f64,
}

impl<'a> CubeSource<'a> {
    pub fn new(cube: &'a Cubemap) -> Self {
        let s = cube.size;
        let omega = cube::face_solid_angles(s);
        let magnitude = (0..cube.texel_count()).map(|t| max_abs(cube.texel(t)) * omega[t % (s * s)]).sum();
        CubeSource { cube, magnitude }
    }
}

impl SphereSource for CubeSource<'_> {
    fn texel_of(&self, d: DVec3) -> usize {
        cube::texel_index_of_direction(d, self.cube.size)
    }
    fn rgb(&self, t: usize) -> [f64; 3] {
        self.cube.texel(t).map(f64::from)
    }
    fn texel_angle(&self) -> f64 {
        // 2 / S at a face's centre; half that allows for the smaller texels towards the corners.
        1.0 / self.cube.size as f64
    }
    fn magnitude(&self) -> f64 {
        self.magnitude
    }
}

/// An N x N equal-area octahedral image.
pub struct OctahedralSource<'a> {
    img: &'a Image,
    magnitude: f64,
}

impl<'a> OctahedralSource<'a> {
    pub fn new(img: &'a Image) -> Self {
        let n = img.width;
        let omega = 4.0 * PI / (n * n).max(1) as f64;
        let magnitude = (0..n * n).map(|t| max_abs(img.rgb(t % n, t / n)) * omega).sum();
        OctahedralSource { img, magnitude }
    }
}

impl SphereSource for OctahedralSource<'_> {
    fn texel_of(&self, d: DVec3) -> usize {
        let n = self.img.width;
        let (x, y) = octahedral::texel_of_direction(d, n);
        y * n + x
    }
    fn rgb(&self, t: usize) -> [f64; 3] {
        self.img.rgb(t % self.img.width, t / self.img.width).map(f64::from)
    }
    fn texel_angle(&self) -> f64 {
        // sqrt(4 pi) / N on average; half that allows for the mapping's shear near the diagonals.
        0.5 * (4.0 * PI).sqrt() / self.img.width as f64
    }
    fn magnitude(&self) -> f64 {
        self.magnitude
    }
}

fn max_abs(v: [f32; 3]) -> f64 {
    v.iter().fold(0.0f64, |m, &c| m.max((c as f64).abs()))
}

/// The parametrisation of an output texel's footprint: (p, q) to a direction, and the exact solid
/// angle of a (p, q) rectangle (`maths::resample::disc_image` adds the azimuthal discs).
pub(crate) trait Footprint: Sync {
    fn dir(&self, p: f64, q: f64) -> DVec3;
    fn solid_angle(&self, p0: f64, p1: f64, q0: f64, q1: f64) -> f64;
    /// The cell `r = [p0, p1, q0, q1]` lies wholly in the domain, its density (solid angle per unit
    /// area) smooth over it: the cut cells of `maths::resample::cut_cells` may integrate it.
    fn whole(&self, _r: [f64; 4]) -> bool {
        true
    }
    /// The density across the cell `r` of solid angle `omega` taken linear, `1 + b_p u + b_q v`
    /// in cell coordinates `(u, v)` in `[-1/2, 1/2]^2`: `[b_p, b_q]`, from its halves' solid angles.
    fn slopes(&self, [p0, p1, q0, q1]: [f64; 4], omega: f64) -> [f64; 2] {
        if omega.is_nan() || omega <= 0.0 {
            return [0.0; 2];
        }
        let (pm, qm) = (0.5 * (p0 + p1), 0.5 * (q0 + q1));
        [
            4.0 * (self.solid_angle(pm, p1, q0, q1) - self.solid_angle(p0, pm, q0, q1)) / omega,
            4.0 * (self.solid_angle(p0, p1, qm, q1) - self.solid_angle(p0, p1, q0, qm)) / omega,
        ]
    }
}

/// A cube face: p = a, q = b.
struct Face(usize);
impl Footprint for Face {
    fn dir(&self, p: f64, q: f64) -> DVec3 {
        cube::face_direction(self.0, p, q)
    }
    fn solid_angle(&self, p0: f64, p1: f64, q0: f64, q1: f64) -> f64 {
        cube::rect_solid_angle(p0, p1, q0, q1)
    }
}

/// The lat-long domain: p = phi, q = theta.
pub(crate) struct LatLongDomain;
impl Footprint for LatLongDomain {
    fn dir(&self, p: f64, q: f64) -> DVec3 {
        DVec3::from(latlong::direction(q, p))
    }
    fn solid_angle(&self, p0: f64, p1: f64, q0: f64, q1: f64) -> f64 {
        (p1 - p0) * (q0.cos() - q1.cos())
    }
    fn slopes(&self, [_, _, q0, q1]: [f64; 4], _omega: f64) -> [f64; 2] {
        let (c0, cm, c1) = (q0.cos(), (0.5 * (q0 + q1)).cos(), q1.cos());
        // No change along phi; along theta, the halves' difference (the same formula as above).
        [0.0, if c0 > c1 { 4.0 * ((cm - c1) - (c0 - cm)) / (c0 - c1) } else { 0.0 }]
    }
}

/// The octahedral unit square.
struct OctDomain;
impl Footprint for OctDomain {
    fn dir(&self, p: f64, q: f64) -> DVec3 {
        octahedral::square_to_direction([p, q])
    }
    fn solid_angle(&self, p0: f64, p1: f64, q0: f64, q1: f64) -> f64 {
        4.0 * PI * (p1 - p0) * (q1 - q0)
    }
}

/// Subdivision limits (see the module documentation).
pub(crate) struct Limits {
    pub(crate) forced: u32,
    pub(crate) boundary: u32,
    pub(crate) max: u32,
    pub(crate) tol: f64,
}

impl Limits {
    pub(crate) fn new<S: SphereSource>(src: &S, out_texel_angle: f64) -> Limits {
        Limits::with_tolerance(src, out_texel_angle, 1e-7, 8)
    }
    /// `rel_tol` times the source's magnitude per leaf, down to `2^-depth` of a source texel.
    pub(crate) fn with_tolerance<S: SphereSource>(src: &S, out_texel_angle: f64, rel_tol: f64, depth: u32) -> Limits {
        let ratio = out_texel_angle / src.texel_angle();
        let forced = if ratio > 1.0 { ratio.log2().ceil().min(24.0) as u32 } else { 0 };
        Limits { forced, boundary: forced + 1, max: forced + depth, tol: rel_tol * src.magnitude() }
    }
}

/// Adds the integral of `src` over the cell `r = [p0, p1, q0, q1]` to `acc` (and its solid angle to
/// `weight`); `corners` are the source texels at (p0, q0), (p1, q0), (p0, q1), (p1, q1), shared
/// with the neighbouring cells so that each grid point is looked up once.
#[allow(clippy::too_many_arguments)]
fn integrate<S: SphereSource, F: Footprint>(
    src: &S,
    fp: &F,
    r: [f64; 4],
    corners: [usize; 4],
    depth: u32,
    lim: &Limits,
    acc: &mut [f64; 3],
    weight: &mut f64,
) {
    let [p0, p1, q0, q1] = r;
    let (pm, qm) = (0.5 * (p0 + p1), 0.5 * (q0 + q1));
    let c = src.texel_of(fp.dir(pm, qm));
    let split = |acc: &mut [f64; 3], weight: &mut f64| {
        let at = |p: f64, q: f64| src.texel_of(fp.dir(p, q));
        let (eb, el, er, et) = (at(pm, q0), at(p0, qm), at(p1, qm), at(pm, q1));
        let [c00, c10, c01, c11] = corners;
        for (rr, cc) in [
            ([p0, pm, q0, qm], [c00, eb, el, c]),
            ([pm, p1, q0, qm], [eb, c10, c, er]),
            ([p0, pm, qm, q1], [el, c, c01, et]),
            ([pm, p1, qm, q1], [c, er, et, c11]),
        ] {
            integrate(src, fp, rr, cc, depth + 1, lim, acc, weight);
        }
    };
    if depth < lim.forced {
        return split(acc, weight);
    }
    let omega = fp.solid_angle(p0, p1, q0, q1);
    if depth < lim.max && corners.iter().any(|&t| t != c) {
        let vc = src.rgb(c);
        let mut spread = 0.0f64;
        let mut scale = vc.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for t in corners {
            let v = src.rgb(t);
            for k in 0..3 {
                spread = spread.max((v[k] - vc[k]).abs());
                scale = scale.max(v[k].abs());
            }
        }
        if (depth < lim.boundary && spread > 1e-2 * scale) || spread * omega > lim.tol {
            return split(acc, weight);
        }
    }
    let v = src.rgb(c);
    for k in 0..3 {
        acc[k] += v[k] * omega;
    }
    *weight += omega;
}

/// The solid-angle mean of `src` over the cell `r = [p0, p1, q0, q1]` of `fp`.
pub(crate) fn average<S: SphereSource, F: Footprint>(src: &S, fp: &F, r: [f64; 4], lim: &Limits) -> [f32; 3] {
    let mut acc = [0.0; 3];
    let mut weight = 0.0;
    let [p0, p1, q0, q1] = r;
    let corners = [(p0, q0), (p1, q0), (p0, q1), (p1, q1)].map(|(p, q)| src.texel_of(fp.dir(p, q)));
    integrate(src, fp, r, corners, 0, lim, &mut acc, &mut weight);
    normalised(acc, weight)
}

/// The cube map of face size `size` whose texels average `src` over their footprints.
pub fn to_cube<S: SphereSource>(src: &S, size: usize) -> Cubemap {
    let lim = Limits::new(src, 2.0 / size as f64);
    Cubemap::from_fn(size, |face, x, y| {
        let r = [cube::edge(x, size), cube::edge(x + 1, size), cube::edge(y, size), cube::edge(y + 1, size)];
        average(src, &Face(face), r, &lim)
    })
}

/// The W x H lat-long RGB image whose texels average `src` over their footprints.
pub fn to_latlong<S: SphereSource>(src: &S, width: usize, height: usize) -> Image {
    latlong_with_limits(src, width, height, &Limits::new(src, PI / height as f64))
}

/// [`to_latlong`] with a tighter quadrature: each leaf's error below `rel_tol` times the source's
/// magnitude, cells down to `2^-depth` of a source texel (a rotation, which must keep the
/// integral to 1e-4 even when a few sun texels carry most of it, uses 1e-9 and 12).
pub fn to_latlong_precise<S: SphereSource>(src: &S, width: usize, height: usize, rel_tol: f64, depth: u32) -> Image {
    latlong_with_limits(src, width, height, &Limits::with_tolerance(src, PI / height as f64, rel_tol, depth))
}

fn latlong_with_limits<S: SphereSource>(src: &S, width: usize, height: usize, lim: &Limits) -> Image {
    let mut out = Image::new(width, height, 3);
    let (dp, dq) = (2.0 * PI / width as f64, PI / height as f64);
    out.data.par_chunks_mut(3 * width).enumerate().for_each(|(y, row)| {
        for x in 0..width {
            let r = [dp * x as f64, dp * (x + 1) as f64, dq * y as f64, dq * (y + 1) as f64];
            row[3 * x..3 * x + 3].copy_from_slice(&average(src, &LatLongDomain, r, lim));
        }
    });
    out
}

/// The N x N equal-area octahedral RGB image whose texels average `src` over their footprints.
pub fn to_octahedral<S: SphereSource>(src: &S, n: usize) -> Image {
    let mut out = Image::new(n, n, 3);
    let lim = Limits::new(src, (4.0 * PI).sqrt() / n as f64);
    let d = 1.0 / n as f64;
    out.data.par_chunks_mut(3 * n).enumerate().for_each(|(y, row)| {
        for x in 0..n {
            let r = [d * x as f64, d * (x + 1) as f64, d * y as f64, d * (y + 1) as f64];
            row[3 * x..3 * x + 3].copy_from_slice(&average(src, &OctDomain, r, &lim));
        }
    });
    out
}

/// A resampling of every channel of `img`, three at a time: `f` resamples the RGB view
/// [`LatLongSource::channels`] of channels `(k, k + 1, k + 2)` (the last ones repeated when fewer
/// are left) to a `width x height` RGB image, and the channels are gathered back, names kept.
pub fn per_channel_triples(img: &Image, width: usize, height: usize, f: impl Fn(&LatLongSource) -> Image) -> Image {
    let c = img.channels;
    let mut out = Image::with_names(width, height, img.names.clone(), vec![0.0; width * height * c]);
    for first in (0..c).step_by(3) {
        let pick = [first, (first + 1).min(c - 1), (first + 2).min(c - 1)];
        let resampled = f(&LatLongSource::channels(img, pick));
        for (px_out, px) in out.data.chunks_exact_mut(c).zip(resampled.data.chunks_exact(3)) {
            for (j, &k) in pick.iter().enumerate() {
                px_out[k] = px[j];
            }
        }
    }
    out
}

/// The integral of a lat-long map over the sphere, per channel (midpoint solid angles).
pub fn latlong_integral(img: &Image) -> [f64; 3] {
    let (w, h) = (img.width, img.height);
    let mut sum = [0.0; 3];
    for y in 0..h {
        let o = latlong::texel_solid_angle(y, w, h);
        for x in 0..w {
            let v = img.rgb(x, y);
            for k in 0..3 {
                sum[k] += v[k] as f64 * o;
            }
        }
    }
    sum
}

/// The integral of a cube map over the sphere, per channel (exact texel solid angles).
pub fn cube_integral(c: &Cubemap) -> [f64; 3] {
    let s = c.size;
    let omega = cube::face_solid_angles(s);
    let mut sum = [0.0; 3];
    for t in 0..c.texel_count() {
        let v = c.texel(t);
        for k in 0..3 {
            sum[k] += v[k] as f64 * omega[t % (s * s)];
        }
    }
    sum
}

/// The integral of an N x N octahedral map over the sphere (every texel 4 pi / N^2).
pub fn octahedral_integral(img: &Image) -> [f64; 3] {
    let n = img.width;
    let o = 4.0 * PI / (n * n).max(1) as f64;
    let mut sum = [0.0; 3];
    for y in 0..n {
        for x in 0..n {
            let v = img.rgb(x, y);
            for k in 0..3 {
                sum[k] += v[k] as f64 * o;
            }
        }
    }
    sum
}

/// Halves a cube map of even size: each texel is the solid-angle-weighted mean of its 2 x 2
/// children (energy-preserving); an odd size is resampled by [`to_cube`] to `size / 2`.
pub fn downsample(c: &Cubemap) -> Cubemap {
    let s = c.size;
    if s <= 1 {
        return c.clone();
    }
    if s % 2 == 1 {
        return to_cube(&CubeSource::new(c), s / 2);
    }
    let h = s / 2;
    let omega = cube::face_solid_angles(s);
    let mut out = Cubemap::new(h);
    out.data.par_chunks_mut(3 * h).enumerate().for_each(|(row, texels)| {
        let (f, y) = (row / h, row % h);
        for x in 0..h {
            let mut acc = [0.0f64; 3];
            let mut w = 0.0;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (cx, cy) = (2 * x + dx, 2 * y + dy);
                let o = omega[cy * s + cx];
                let v = c.texel((f * s + cy) * s + cx);
                for k in 0..3 {
                    acc[k] += v[k] as f64 * o;
                }
                w += o;
            }
            for k in 0..3 {
                texels[3 * x + k] = (acc[k] / w) as f32;
            }
        }
    });
    out
}

/// `acc / weight` as RGB, black when the weight is not positive.
#[inline]
pub fn normalised(acc: [f64; 3], weight: f64) -> [f32; 3] {
    if weight > 0.0 {
        acc.map(|v| (v / weight) as f32)
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests;
