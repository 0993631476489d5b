//! Tests of the `Area` integrator: exact means over four constant quadrants and a brute force.

use glam::DVec3;

use super::*;
use crate::geometry::rotation::Rotation;

/// The part of convex polygon `poly` where `a X + b Y + c >= 0`.
fn clip_line(poly: &[[f64; 2]], (a, b, c): (f64, f64, f64)) -> Vec<[f64; 2]> {
    let g = |p: [f64; 2]| a * p[0] + b * p[1] + c;
    let mut out = Vec::new();
    for k in 0..poly.len() {
        let (p, q) = (poly[(k + poly.len() - 1) % poly.len()], poly[k]);
        let (gp, gq) = (g(p), g(q));
        if (gp >= 0.0) != (gq >= 0.0) {
            let t = gp / (gp - gq);
            out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
        }
        if gq >= 0.0 {
            out.push(q);
        }
    }
    out
}

/// The solid angle of a convex polygon on the perspective plane z = -1: a fan of spherical
/// triangles, `tan(Omega / 2) = |a.(b x c)| / (1 + a.b + b.c + c.a)` (Van Oosterom and
/// Strackee 1983).
fn polygon_solid_angle(poly: &[[f64; 2]]) -> f64 {
    let unit = |p: [f64; 2]| DVec3::new(p[0], p[1], -1.0).normalize();
    (1..poly.len().saturating_sub(1))
        .map(|k| {
            let (a, b, c) = (unit(poly[0]), unit(poly[k]), unit(poly[k + 1]));
            2.0 * a.dot(b.cross(c)).abs().atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
        })
        .sum()
}

/// The map `1 + [d.x > 0] + 2 [d.y < 0]`: its texel edges at columns 0 and W/2 and at row
/// H/2 lie on the planes x = 0 and y = 0, so it is exactly that function of direction.
fn quadrants(w: usize, h: usize) -> Image {
    Image::from_vec(
        w,
        h,
        1,
        (0..w * h).map(|k| 1.0 + ((k % w) >= w / 2) as u8 as f32 + 2.0 * ((k / w) >= h / 2) as u8 as f32).collect(),
    )
}

/// The exact mean of [`quadrants`] over pixel (i, j) of a perspective view: the pixel's
/// plane rectangle cut by the two planes' lines, each piece a spherical polygon.
fn exact_quadrant_mean(lens: &Lens, r: Rotation, i: usize, j: usize) -> f64 {
    let t = lens.half.tan();
    let (x0, y0) = lens.plane(i as f64, j as f64 + 1.0);
    let (x1, y1) = lens.plane(i as f64 + 1.0, j as f64);
    let rect = [[x0 * t, y0 * t], [x1 * t, y0 * t], [x1 * t, y1 * t], [x0 * t, y1 * t]];
    // d = R c with c = (X, Y, -1): d.x = c.(R^T e_x), d.y = c.(R^T e_y).
    let (nx, ny) = (r.inverse().apply(DVec3::X), r.inverse().apply(DVec3::Y));
    let line = |n: DVec3, sign: f64| (sign * n.x, sign * n.y, -sign * n.z);
    let (mut sum, mut total) = (0.0, 0.0);
    for (sx, sy) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let piece = clip_line(&clip_line(&rect, line(nx, sx)), line(ny, -sy));
        let omega = polygon_solid_angle(&piece);
        sum += omega * (1.0 + (sx > 0.0) as u8 as f64 + 2.0 * (sy > 0.0) as u8 as f64);
        total += omega;
    }
    sum / total
}

#[test]
fn the_mean_over_four_quadrants_is_exact() {
    for (w, h) in [(64, 32), (512, 256)] {
        let env = quadrants(w, h);
        for angles in [(20.0, 10.0, 0.0), (20.0, 10.0, 30.0)] {
            let r = Rotation::from_yaw_pitch_roll(angles.0, angles.1, angles.2);
            let lens = Lens::new(Model::Perspective, 100.0, 24, 18).unwrap();
            let view = project_area(&env, &lens, r.0);
            let mut mixed = 0;
            for j in 0..18 {
                for i in 0..24 {
                    let (got, want) = (view.data[j * 24 + i] as f64, exact_quadrant_mean(&lens, r, i, j));
                    assert!((got - want).abs() < 5e-4, "{w}x{h} {angles:?} ({i}, {j}): {got} vs {want}");
                    mixed += (want.fract() != 0.0) as usize;
                }
            }
            assert!(mixed >= 24, "the planes cross only {mixed} pixels");
        }
    }
}

/// The Area mean by brute force: n x n sub-rays per pixel, each weighted by its cell's
/// solid angle, reading the texel its centre ray hits (cells with no ray at a corner or the
/// centre left out: beyond the disc their solid angle is rounding).
fn brute_force(env: &Image, lens: &Lens, r: DMat3, n: usize) -> Vec<f64> {
    let (w, h) = (lens.width, lens.height);
    (0..w * h)
        .into_par_iter()
        .map(|k| {
            let (i, j, step) = ((k % w) as f64, (k / w) as f64, 1.0 / n as f64);
            let (mut acc, mut weight) = (0.0, 0.0);
            for s in 0..n * n {
                let (a, b) = ((s % n) as f64 * step, (s / n) as f64 * step);
                let (xa, ya) = lens.plane(i + a, j + b + step);
                let (xb, yb) = lens.plane(i + a + step, j + b);
                let (xm, ym) = (0.5 * (xa + xb), 0.5 * (ya + yb));
                if ![(xa, ya), (xb, ya), (xa, yb), (xb, yb), (xm, ym)].iter().any(|&(x, y)| lens.has_ray(x, y)) {
                    continue;
                }
                let omega = lens.rect_solid_angle(xa, xb, ya, yb);
                let d = r * lens.ray_clamped(xm, ym);
                let (tx, ty) = latlong::texel_of_direction(d.into(), env.width, env.height);
                acc += omega * env.pixel(tx, ty)[0] as f64;
                weight += omega;
            }
            if weight > 0.0 {
                acc / weight
            } else {
                0.0
            }
        })
        .collect()
}

#[test]
fn the_mean_agrees_with_a_brute_force_average_on_texel_noise() {
    let (w, h) = (128, 64);
    let env = Image::from_vec(w, h, 1, (0..w * h).map(|i| ((i * 7919) % 101) as f32 * 0.01 + 1.0).collect());
    let r = Rotation::from_yaw_pitch_roll(40.0, -15.0, 5.0).0;
    for (model, fov) in [(Model::Perspective, 70.0), (Model::Fisheye, 200.0), (Model::Orthographic, 180.0)] {
        let lens = Lens::new(model, fov, 16, 12).unwrap();
        let view = project_area(&env, &lens, r);
        let brute = brute_force(&env, &lens, r, 384);
        let (mut inside, mut rim) = (0.0f64, 0.0f64);
        for (k, (&got, &want)) in view.data.iter().zip(&brute).enumerate() {
            let (i, j) = ((k % 16) as f64, (k / 16) as f64);
            let (x0, y0) = lens.plane(i, j + 1.0);
            let (x1, y1) = lens.plane(i + 1.0, j);
            let whole = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].iter().all(|&(x, y)| lens.has_ray(x, y));
            let e = (got as f64 - want).abs();
            if whole {
                inside = inside.max(e);
            } else {
                rim = rim.max(e);
            }
        }
        assert!(inside < 1e-3 && rim < 1e-2, "{model}: {inside} inside, {rim} on the rim");
    }
}
