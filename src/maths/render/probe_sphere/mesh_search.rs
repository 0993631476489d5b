//! The mesh's ray queries: the nearest hit ([`SphereMesh::hit_near`]) and whether a ray hits at all
//! ([`SphereMesh::hits`], the coverage of the rough spheres' rays), each trying first the triangles
//! around the last one hit, then the lookup grid.
//!
//! **Around the hint.** Rays of a pixel, and of neighbouring pixels, land on the same triangle or
//! one that shares a vertex with it (triangles are ~14 pixels across at 960 x 540). The mesh is
//! convex but for dents at most 2.2e-3 deep where a non-planar quad is split across its valley
//! (tested), under triangles about 0.1 wide: a ray that enters any triangle from its front more
//! steeply than [`HINT_MIN_COS`] cannot have left and re-entered the sphere before, so that hit is
//! the nearest, whichever triangle it is. So the hinted triangle and then its ring (the triangles
//! sharing a vertex with it, edge neighbours first) are tried under that rule; a grazing ray, or
//! one that left the ring, takes the grid.
//!
//! **The grid** ([`super::mesh`]): the triangles of the cells of points along the ray's segment in
//! the shell are tested once each (a per-thread stamp per triangle, instead of sorting the cells'
//! lists), the nearest hit winning, the lower id on a tie, so the hit is that of testing every
//! triangle (tested).
//!
//! **Any hit.** The mesh is closed: a ray hits it when it hits any triangle, so [`SphereMesh::hits`]
//! stops at the first (ring or grid), whatever its steepness; and a ray through the ball of radius
//! `inner`, which lies inside the mesh, hits it without a test (tested against every triangle).

use std::cell::RefCell;

use super::camera::Ray;
use super::mesh::{shell_segment, Hit, SphereMesh, SEGMENT_STEP};

/// The steepness (cosine from the triangle's plane normal) above which a hit on a triangle near the
/// hint is taken without a search: 11.5 degrees from grazing, twice the steepest slope a dent can
/// hide a nearer hit under (atan(2 * 2.2e-3 / 0.05)).
pub const HINT_MIN_COS: f64 = 0.2;

thread_local! {
    /// Per triangle, the query that last tested it, and the current query's number.
    static STAMPS: RefCell<(u32, Vec<u32>)> = const { RefCell::new((0, Vec::new())) };
}

impl SphereMesh {
    /// The nearest hit of `ray`, trying first the triangle `hint` names and its ring (see the
    /// module documentation), and leaving in `hint` the triangle hit.
    pub fn hit_near(&self, ray: &Ray, hint: &mut Option<usize>) -> Option<Hit> {
        if let Some(h) = *hint {
            for id in std::iter::once(h).chain(self.rings[h].iter().map(|&i| i as usize)) {
                if self.face_normals[id].dot(ray.dir) < -HINT_MIN_COS {
                    if let Some((t, u, v)) = self.intersect(id, ray) {
                        *hint = Some(id);
                        return Some(self.hit_at(ray, id, t, u, v));
                    }
                }
            }
        }
        let mut best: Option<(f64, usize, f64, f64)> = None;
        self.each_candidate(ray, |id, past| {
            // Every triangle a nearer hit could be on was listed at a point before `past`.
            if best.is_some_and(|b| past > b.0) {
                return true;
            }
            if let Some((t, u, v)) = self.intersect(id, ray) {
                if best.is_none_or(|b| t < b.0 || (t == b.0 && id < b.1)) {
                    best = Some((t, id, u, v));
                }
            }
            false
        });
        let (t, id, u, v) = best?;
        *hint = Some(id);
        Some(self.hit_at(ray, id, t, u, v))
    }

    /// Whether `ray` hits the mesh (any triangle), trying first the triangle `hint` names and its
    /// ring; leaves in `hint` a triangle hit.
    pub fn hits(&self, ray: &Ray, hint: &mut Option<usize>) -> bool {
        // The ball of radius `inner` clears every triangle's plane and holds the origin, so it lies
        // inside the closed mesh: a ray from outside that passes through it crosses the mesh. Most
        // of the rough spheres' silhouette rays do, and skip the search (the hint is kept).
        if through_ball(ray, self.inner) {
            return true;
        }
        if let Some(h) = *hint {
            for id in std::iter::once(h).chain(self.rings[h].iter().map(|&i| i as usize)) {
                if self.intersect(id, ray).is_some() {
                    *hint = Some(id);
                    return true;
                }
            }
        }
        let mut found = None;
        self.each_candidate(ray, |id, _| {
            if self.intersect(id, ray).is_some() {
                found = Some(id);
                return true;
            }
            false
        });
        if found.is_some() {
            *hint = found;
        }
        found.is_some()
    }

    /// Calls `test(id, past)` once on each triangle of the cells of points along the ray's segment
    /// in the shell, in the order of the points, until it returns true. `past` is the distance
    /// along the ray one point spacing before the current point: the triangles through which the
    /// ray passes at distances below it were all listed at the points already visited (a point
    /// of the segment is within half a spacing of one of the two points around it, well within
    /// the boxes' padding), so a nearest-hit search that has a hit nearer than `past` can stop.
    fn each_candidate(&self, ray: &Ray, mut test: impl FnMut(usize, f64) -> bool) {
        let Some((t0, t1)) = shell_segment(ray, self.outer, self.inner) else { return };
        STAMPS.with(|stamps| {
            let mut stamps = stamps.borrow_mut();
            let (query, seen) = &mut *stamps;
            if seen.len() != self.triangles.len() || *query == u32::MAX {
                *seen = vec![0; self.triangles.len()];
                *query = 0;
            }
            *query += 1;
            let query = *query;
            let (d0, d1) = (ray.origin + t0 * ray.dir, ray.origin + t1 * ray.dir);
            let span = d0.angle_between(d1);
            let points = ((span / SEGMENT_STEP).ceil() as usize + 1).max(2);
            let mut last_cell = usize::MAX;
            let spacing = (t1 - t0) / (points - 1) as f64;
            for k in 0..points {
                let t = t0 + (t1 - t0) * k as f64 / (points - 1) as f64;
                let past = t - spacing;
                let cell = self.cell_index(ray.origin + t * ray.dir);
                if cell == last_cell {
                    continue;
                }
                last_cell = cell;
                for &id in &self.cells[cell] {
                    let id = id as usize;
                    if seen[id] == query {
                        continue;
                    }
                    seen[id] = query;
                    if test(id, past) {
                        return;
                    }
                }
            }
        });
    }
}

/// Whether `ray` (from outside the ball) passes through the interior of the ball of radius `r`
/// about the origin, ahead of its origin, with a margin of 1e-9 relative for rounding.
pub(super) fn through_ball(ray: &Ray, r: f64) -> bool {
    let b = ray.origin.dot(ray.dir);
    let closest_squared = ray.origin.length_squared() - b * b;
    b < 0.0 && closest_squared < r * r * (1.0 - 1e-9)
}
