//! The protocol's sphere and the camera rays' hits on it: the unit sphere (`Ideal`) or the mesh
//! Blender renders (`Subdivided`), a UV sphere of 32 segments and 16 rings after one level of
//! Catmull-Clark subdivision, smooth-shaded.
//!
//! The mesh is Blender 3.4.1's own evaluation, dumped by `bench/peers/blender_sphere_mesh.py`
//! into `sphere_mesh.bin` (1986 vertices with their normals, 3968 triangles, Blender world
//! coordinates): subdivision places the vertices on the limit surface, between radius 0.9872 and
//! 0.9976, so the rendered sphere is slightly smaller than the unit sphere and its shading normals
//! are not radial. As in Cycles (`kernel/geom/triangle.h` `triangle_smooth_normal`), the shading
//! normal at a hit is the barycentric interpolation of the three vertex normals, normalised, and the
//! geometric normal `Ng` the triangle's.
//!
//! Intersection ([`super::mesh_search`]): every triangle lies in the shell between the sphere through the farthest vertex
//! and the sphere tangent to the nearest triangle plane, and covers a small patch of directions
//! from the origin (the mesh is star-shaped about it). A ray's hit, if any, lies on its segment
//! inside that shell; the triangles whose patch of directions (an azimuth-polar box, padded by half
//! a cell) meets the directions of points along the segment are tested exactly (Moller-Trumbore,
//! f64), and the nearest hit wins.

use std::collections::HashMap;
use std::sync::OnceLock;

use glam::DVec3;

use super::camera::Ray;
use crate::maths::resample::angles;

/// Where a ray meets the sphere.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// the distance along the ray
    pub t: f64,
    pub point: DVec3,
    /// the shading normal (interpolated and normalised; radial for the ideal sphere)
    pub normal: DVec3,
    /// the geometric normal (the triangle's; radial for the ideal sphere)
    pub ng: DVec3,
}

/// The unit sphere at the origin.
pub fn hit_ideal(ray: &Ray) -> Option<Hit> {
    let b = ray.origin.dot(ray.dir);
    let c = ray.origin.length_squared() - 1.0;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    if t <= 0.0 {
        return None;
    }
    let point = ray.origin + t * ray.dir;
    let normal = point.normalize();
    Some(Hit { t, point, normal, ng: normal })
}

/// The subdivided sphere Blender renders, with its lookup grid.
pub struct SphereMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub(super) face_normals: Vec<DVec3>,
    /// radius of the sphere through the farthest vertex
    pub outer: f64,
    /// distance of the nearest triangle plane from the origin
    pub inner: f64,
    /// triangle ids per grid cell, `cells[polar * AZIMUTH_CELLS + azimuth]`
    pub(super) cells: Vec<Vec<u32>>,
    /// per triangle, the triangles sharing a vertex with it, edge neighbours first
    pub(super) rings: Vec<Vec<u32>>,
}

const AZIMUTH_CELLS: usize = 64;
const POLAR_CELLS: usize = 32;
/// The largest angle, in radians, between the directions of consecutive points along a ray's
/// segment in the shell whose cells are looked up: 1 degree, well within the half-cell (2.8 degree)
/// padding of the triangles' boxes, and half of what the polar cap allows, where that padding is
/// less than a degree of arc (tested: 2 degrees still finds every hit there, 3 do not). A segment
/// spans at most ~18 degrees (a ray grazing the shell).
pub(super) const SEGMENT_STEP: f64 = std::f64::consts::PI / 180.0;

static MESH: OnceLock<SphereMesh> = OnceLock::new();

/// The protocol's subdivided sphere (parsed once).
pub fn subdivided() -> &'static SphereMesh {
    MESH.get_or_init(|| SphereMesh::parse(include_bytes!("sphere_mesh.bin")).expect("the embedded sphere mesh parses"))
}

/// The cell (azimuth, polar) of a direction.
fn cell_of(d: DVec3) -> (usize, usize) {
    let (az, pol) = angles(d);
    let a = ((az / std::f64::consts::TAU) * AZIMUTH_CELLS as f64).floor() as isize;
    let p = ((pol / std::f64::consts::PI) * POLAR_CELLS as f64).floor() as isize;
    (a.rem_euclid(AZIMUTH_CELLS as isize) as usize, p.clamp(0, POLAR_CELLS as isize - 1) as usize)
}

impl SphereMesh {
    /// The grid cell of direction `d`, `polar * AZIMUTH_CELLS + azimuth`.
    pub(super) fn cell_index(&self, d: DVec3) -> usize {
        let (a, p) = cell_of(d);
        p * AZIMUTH_CELLS + a
    }
}

/// Azimuth in [0, 2 pi) about +Z from +X, and polar angle from +Z ([`angles::atan2`]'s, within
/// 2e-15 rad of libm's: far inside the triangles' half-cell padding; every ray's search asks).
fn angles(d: DVec3) -> (f64, f64) {
    let mut az = angles::atan2(d.y, d.x);
    if az < 0.0 {
        az += std::f64::consts::TAU;
    }
    (az, angles::atan2((d.x * d.x + d.y * d.y).sqrt(), d.z))
}

impl SphereMesh {
    /// Parses the dump format of `bench/peers/blender_sphere_mesh.py`.
    pub fn parse(bytes: &[u8]) -> Result<SphereMesh, String> {
        let magic = b"HFSPHERE";
        if bytes.len() < 16 || &bytes[..8] != magic {
            return Err("not a sphere mesh dump".into());
        }
        let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
        let f32_at = |i: usize| f32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as f64;
        let (nv, nt) = (u32_at(8) as usize, u32_at(12) as usize);
        if bytes.len() != 16 + nv * 24 + nt * 12 {
            return Err(format!("a dump of {nv} vertices and {nt} triangles has the wrong length"));
        }
        let mut positions = Vec::with_capacity(nv);
        let mut normals = Vec::with_capacity(nv);
        for i in 0..nv {
            let o = 16 + i * 24;
            positions.push(DVec3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8)));
            normals.push(DVec3::new(f32_at(o + 12), f32_at(o + 16), f32_at(o + 20)).normalize());
        }
        let mut triangles = Vec::with_capacity(nt);
        for i in 0..nt {
            let o = 16 + nv * 24 + i * 12;
            let t = [u32_at(o), u32_at(o + 4), u32_at(o + 8)];
            if t.iter().any(|&v| v as usize >= nv) {
                return Err(format!("triangle {i} names a vertex past {nv}"));
            }
            triangles.push(t);
        }
        Ok(SphereMesh::build(positions, normals, triangles))
    }

    fn build(positions: Vec<DVec3>, normals: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> SphereMesh {
        let p = |i: u32| positions[i as usize];
        let face_normals: Vec<DVec3> = triangles
            .iter()
            .map(|&[a, b, c]| {
                let n = (p(b) - p(a)).cross(p(c) - p(a)).normalize();
                // Outward: Blender's winding gives it; keep it so whatever the dump's order.
                if n.dot(p(a) + p(b) + p(c)) < 0.0 {
                    -n
                } else {
                    n
                }
            })
            .collect();
        let outer = positions.iter().map(|v| v.length()).fold(0.0, f64::max) * (1.0 + 1e-12);
        let inner =
            triangles.iter().zip(&face_normals).map(|(t, n)| n.dot(p(t[0])).abs()).fold(f64::INFINITY, f64::min)
                * (1.0 - 1e-12);
        let mut cells = vec![Vec::new(); AZIMUTH_CELLS * POLAR_CELLS];
        let (cell_az, cell_pol) =
            (std::f64::consts::TAU / AZIMUTH_CELLS as f64, std::f64::consts::PI / POLAR_CELLS as f64);
        for (id, tri) in triangles.iter().enumerate() {
            let dirs = tri.map(p);
            let pol: Vec<f64> = dirs.iter().map(|d| angles(*d).1).collect();
            let (p0, p1) = (pol.iter().cloned().fold(f64::INFINITY, f64::min), pol.iter().cloned().fold(0.0, f64::max));
            let at_pole = dirs.iter().any(|d| d.x.hypot(d.y) < 1e-6 * d.length());
            // Azimuths unwrapped about the first off-pole vertex.
            let azs: Vec<f64> =
                dirs.iter().filter(|d| d.x.hypot(d.y) >= 1e-6 * d.length()).map(|d| angles(*d).0).collect();
            let (a0, a1) = if at_pole || azs.is_empty() {
                (0.0, std::f64::consts::TAU)
            } else {
                let base = azs[0];
                let un: Vec<f64> = azs
                    .iter()
                    .map(|&a| {
                        base + (a - base + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                            - std::f64::consts::PI
                    })
                    .collect();
                (un.iter().cloned().fold(f64::INFINITY, f64::min), un.iter().cloned().fold(f64::NEG_INFINITY, f64::max))
            };
            let pr = (((p0 / cell_pol) - 0.5).floor().max(0.0) as usize)
                ..=((((p1 / cell_pol) + 0.5).floor() as usize).min(POLAR_CELLS - 1));
            let ar: Vec<usize> = if at_pole {
                (0..AZIMUTH_CELLS).collect()
            } else {
                let (lo, hi) = (((a0 / cell_az) - 0.5).floor() as isize, ((a1 / cell_az) + 0.5).floor() as isize);
                (lo..=hi).map(|a| a.rem_euclid(AZIMUTH_CELLS as isize) as usize).collect()
            };
            for pc in pr {
                for &ac in &ar {
                    let cell = &mut cells[pc * AZIMUTH_CELLS + ac];
                    if cell.last() != Some(&(id as u32)) {
                        cell.push(id as u32);
                    }
                }
            }
        }
        let rings = rings(&triangles, positions.len());
        SphereMesh { positions, normals, triangles, face_normals, outer, inner, cells, rings }
    }

    /// The nearest hit of `ray` on the mesh.
    pub fn hit(&self, ray: &Ray) -> Option<Hit> {
        self.hit_near(ray, &mut None)
    }

    pub(super) fn hit_at(&self, ray: &Ray, id: usize, t: f64, u: f64, v: f64) -> Hit {
        let [a, b, c] = self.triangles[id].map(|i| i as usize);
        let n = (1.0 - u - v) * self.normals[a] + u * self.normals[b] + v * self.normals[c];
        let ng = self.face_normals[id];
        let normal = if n.length_squared() > 0.0 { n.normalize() } else { ng };
        Hit { t, point: ray.origin + t * ray.dir, normal, ng }
    }

    /// Moller-Trumbore: `(t, u, v)` with the hit at `(1 - u - v) p0 + u p1 + v p2`.
    pub(super) fn intersect(&self, id: usize, ray: &Ray) -> Option<(f64, f64, f64)> {
        let t = &self.triangles[id];
        let (a, b, c) = (self.positions[t[0] as usize], self.positions[t[1] as usize], self.positions[t[2] as usize]);
        let (e1, e2) = (b - a, c - a);
        let pv = ray.dir.cross(e2);
        let det = e1.dot(pv);
        if det.abs() < 1e-300 {
            return None;
        }
        let inv = 1.0 / det;
        let tv = ray.origin - a;
        let u = tv.dot(pv) * inv;
        let qv = tv.cross(e1);
        let v = ray.dir.dot(qv) * inv;
        // A hair of tolerance so that a ray through a shared edge is never lost between triangles.
        const EPS: f64 = 1e-12;
        if u < -EPS || v < -EPS || u + v > 1.0 + EPS {
            return None;
        }
        let t = e2.dot(qv) * inv;
        (t > 0.0).then_some((t, u, v))
    }
}

/// Per triangle, the triangles that share a vertex with it: those sharing an edge first.
fn rings(triangles: &[[u32; 3]], vertices: usize) -> Vec<Vec<u32>> {
    let mut at_vertex = vec![Vec::new(); vertices];
    for (id, t) in triangles.iter().enumerate() {
        for &v in t {
            at_vertex[v as usize].push(id as u32);
        }
    }
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (id, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(id as u32);
        }
    }
    triangles
        .iter()
        .enumerate()
        .map(|(id, t)| {
            let mut ring: Vec<u32> = Vec::new();
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                for &n in &edges[&(a.min(b), a.max(b))] {
                    if n as usize != id && !ring.contains(&n) {
                        ring.push(n);
                    }
                }
            }
            for &v in t {
                for &n in &at_vertex[v as usize] {
                    if n as usize != id && !ring.contains(&n) {
                        ring.push(n);
                    }
                }
            }
            ring
        })
        .collect()
}

/// The part `[t0, t1]` of a ray inside the sphere of radius `outer` and before the sphere of radius
/// `inner` (where it reaches it).
pub(super) fn shell_segment(ray: &Ray, outer: f64, inner: f64) -> Option<(f64, f64)> {
    let b = ray.origin.dot(ray.dir);
    let c0 = ray.origin.length_squared();
    let disc = b * b - (c0 - outer * outer);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let (t0, mut t1) = (-b - s, -b + s);
    let disc_in = b * b - (c0 - inner * inner);
    if disc_in >= 0.0 {
        t1 = -b - disc_in.sqrt();
    }
    (t1 > 0.0).then_some((t0.max(0.0), t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_mesh_is_blenders_subdivided_uv_sphere() {
        let m = subdivided();
        assert_eq!((m.positions.len(), m.triangles.len()), (1986, 3968));
        assert!(m.outer > 0.9975 && m.outer < 0.9977, "{}", m.outer);
        assert!(m.inner > 0.98 && m.inner < 0.9873, "{}", m.inner);
        // Every triangle is registered somewhere, and the vertex normals point outwards.
        assert!(m.cells.iter().map(|c| c.len()).sum::<usize>() >= m.triangles.len());
        assert!(m.positions.iter().zip(&m.normals).all(|(p, n)| p.dot(*n) > 0.99 * p.length()));
    }

    /// The distance to the nearest hit of `ray` over every triangle (infinite when none).
    fn nearest_of_every_triangle(m: &SphereMesh, ray: &Ray) -> f64 {
        (0..m.triangles.len()).filter_map(|id| m.intersect(id, ray)).map(|(t, _, _)| t).fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn grid_lookup_finds_the_same_hit_as_testing_every_triangle() {
        let m = subdivided();
        let origin = super::super::camera::POSITION;
        let mut hits = 0;
        for i in 0..60 {
            for j in 0..60 {
                // Directions over the sphere's disc and a little beyond it (the silhouette).
                let target = DVec3::new(-1.05 + 2.1 * i as f64 / 59.0, 0.0, -1.05 + 2.1 * j as f64 / 59.0);
                let ray = Ray { origin, dir: (target - origin).normalize() };
                let brute = nearest_of_every_triangle(m, &ray);
                let mut hint = Some((i * 67 + j * 13) % m.triangles.len());
                let hinted = m.hit_near(&ray, &mut hint).map(|h| h.t);
                assert_eq!(hinted, m.hit(&ray).map(|h| h.t), "{i} {j}: a hint changed the hit");
                match m.hit(&ray) {
                    Some(h) => {
                        assert_eq!(h.t, brute, "{i} {j}");
                        assert!(h.ng.dot(ray.dir) < 0.0);
                        hits += 1;
                    }
                    None => assert!(brute.is_infinite(), "{i} {j}: missed a hit at {brute}"),
                }
            }
        }
        assert!(hits > 2000, "{hits}");
    }

    #[test]
    fn any_hit_agrees_with_testing_every_triangle_across_the_silhouette() {
        // Rays from the camera and from points of its lens towards a band around the silhouette,
        // where some pass through the inner ball (taken without a search), some graze the mesh
        // and some miss it.
        let m = subdivided();
        let (mut hit, mut missed, mut through_inner) = (0, 0, 0);
        for (k, lens) in [(0.0, 0.0), (0.085, 0.0), (-0.06, 0.06)].into_iter().enumerate() {
            let origin = super::super::camera::POSITION + DVec3::new(lens.0, 0.0, lens.1);
            for i in 0..2000 {
                let a = i as f64 * 0.0031416 + k as f64;
                let radius = 0.97 + 0.035 * ((i * 7919) % 1000) as f64 / 999.0;
                let target = DVec3::new(radius * a.cos(), 0.0, radius * a.sin());
                let ray = Ray { origin, dir: (target - origin).normalize() };
                let brute = (0..m.triangles.len()).any(|id| m.intersect(id, &ray).is_some());
                let mut hint = Some((i * 31) % m.triangles.len());
                assert_eq!(m.hits(&ray, &mut hint), brute, "lens {k}, ray {i} at radius {radius}");
                if brute {
                    hit += 1;
                } else {
                    missed += 1;
                }
                through_inner += usize::from(super::super::mesh_search::through_ball(&ray, m.inner));
            }
        }
        assert!(hit > 1000 && missed > 1000 && through_inner > 500, "{hit} {missed} {through_inner}");
    }

    #[test]
    fn near_the_pole_the_grid_finds_the_hit_of_testing_every_triangle() {
        // The grid's cells are azimuth-polar boxes, so half a cell of padding is less than a degree
        // of arc around the pole, where the points along a ray's segment are a degree apart: the
        // camera sees the +Z pole 7 degrees inside the disc's top, and rays from the lens cross the
        // polar cap at every angle, grazing near the silhouette. Every hit there, the hinted and
        // the grid's, is the nearest of all the triangles'. (With a step of 3 degrees this test
        // finds missed hits that the two above do not; with 2 degrees it passes: the 1-degree
        // step has twice the margin it needs at the pole.)
        let m = subdivided();
        // Hits within 12 degrees of the pole (the cap's two rings of cells), counted.
        let cap = 12f64.to_radians().cos();
        let (mut hits, mut misses, mut on_cap) = (0, 0, 0);
        for (k, lens) in [(0.0, 0.0), (0.085, 0.0), (-0.06, 0.06), (0.03, -0.08)].into_iter().enumerate() {
            let origin = super::super::camera::POSITION + DVec3::new(lens.0, 0.0, lens.1);
            for i in 0..120 {
                for j in 0..60 {
                    // The disc's top: x across the cap, z from below the pole's image to past the
                    // silhouette.
                    let target = DVec3::new(-0.3 + 0.6 * i as f64 / 119.0, 0.0, 0.86 + 0.16 * j as f64 / 59.0);
                    let ray = Ray { origin, dir: (target - origin).normalize() };
                    let brute = nearest_of_every_triangle(m, &ray);
                    let mut hint = Some((i * 41 + j * 7 + k) % m.triangles.len());
                    let hinted = m.hit_near(&ray, &mut hint).map(|h| h.t);
                    let grid = m.hit(&ray);
                    assert_eq!(hinted, grid.map(|h| h.t), "lens {k}, ray ({i}, {j}): a hint changed the hit");
                    match grid {
                        Some(h) => {
                            assert_eq!(h.t, brute, "lens {k}, ray ({i}, {j})");
                            hits += 1;
                            on_cap += usize::from(h.point.normalize().z > cap);
                        }
                        None => {
                            assert!(brute.is_infinite(), "lens {k}, ray ({i}, {j}): missed a hit at {brute}");
                            misses += 1;
                        }
                    }
                }
            }
        }
        assert!(hits > 15_000 && misses > 5_000 && on_cap > 1_000, "{hits} {misses} {on_cap}");
    }

    #[test]
    fn the_mesh_is_convex_but_for_shallow_dents() {
        let m = subdivided();
        let mut worst: f64 = 0.0;
        for (t, n) in m.triangles.iter().zip(&m.face_normals) {
            let p0 = m.positions[t[0] as usize];
            worst = worst.max(m.positions.iter().map(|p| n.dot(*p - p0)).fold(f64::NEG_INFINITY, f64::max));
        }
        assert!(worst > 0.0 && worst < 2.2e-3, "the deepest dent is {worst}");
    }

    #[test]
    fn the_ideal_sphere_is_hit_at_radius_one() {
        let ray = Ray { origin: DVec3::new(0.0, -16.0, 2.0), dir: DVec3::new(0.0, 16.0, -2.0).normalize() };
        let h = hit_ideal(&ray).unwrap();
        assert!((h.point.length() - 1.0).abs() < 1e-12 && (h.t - (260f64.sqrt() - 1.0)).abs() < 1e-12);
    }
}
