//! Camera views of a lat-long map ([`project`]) and views pasted back into one ([`embed`]),
//! through a [`Lens`] rotated by `R` (world ray `R c` for camera ray `c`; see `geometry::lens`).
//!
//! - [`Filter::Bilinear`]: each pixel is the bilinear lookup of the map (`maths::resample::bilinear::latlong`)
//!   along the ray through its centre.
//! - [`Filter::Area`]: each pixel is the solid-angle mean of the piecewise-constant map over the
//!   pixel's footprint (`maths::camera::area`): a constant map gives exactly the constant; a
//!   pixel whose footprint has no ray (beyond the fisheye circle) is 0, and one that the circle
//!   crosses averages over the part with rays.
//!
//! Pixels with no ray are 0 with either filter. The tests check: every pixel of a map holding
//! its own directions sees its ray (both filters, every model, to the map's interpolation
//! error); the Area mean of a constant is the constant bit for bit, and of a smooth map over
//! the whole view its closed form; and [`embed`] of a [`project`] returns the map.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::lens::Lens;
use crate::geometry::rotation::Rotation;
use crate::maths::camera::area::project_area;
use crate::maths::resample::bilinear;
use crate::values::Image;

crate::choice! {
    /// How a pixel reads the map.
    pub enum Filter {
        /// The bilinear lookup along the ray through the pixel's centre.
        Bilinear,
        /// The solid-angle mean of the map over the pixel's footprint.
        Area,
    }
}

/// The `lens.width` x `lens.height` view of lat-long map `env` (any channels) through `lens`
/// rotated by `rotation`; channel names kept.
pub fn project(env: &Image, lens: &Lens, rotation: Rotation, filter: Filter) -> Image {
    match filter {
        Filter::Bilinear => project_bilinear(env, lens, rotation.0),
        Filter::Area => project_area(env, lens, rotation.0),
    }
}

fn project_bilinear(env: &Image, lens: &Lens, r: DMat3) -> Image {
    let (w, c) = (lens.width, env.channels);
    let mut out = Image::with_names(w, lens.height, env.names.clone(), vec![0.0; w * lens.height * c]);
    out.data.par_chunks_mut(w * c).enumerate().for_each(|(j, row)| {
        let mut acc = vec![0.0; c];
        for i in 0..w {
            if let Some(ray) = lens.pixel_ray(i, j) {
                bilinear::latlong(env, r * ray, &mut acc);
                for (o, &a) in row[i * c..(i + 1) * c].iter_mut().zip(&acc) {
                    *o = a as f32;
                }
            }
        }
    });
    out
}

/// `view` (any channels) pasted into lat-long map `env` (the same channels) through `lens`
/// rotated by `rotation`: each texel whose centre direction `d` has a plane point
/// `lens.plane_of(R^T d)` inside the frame takes the bilinear lookup of `view` there, over the
/// taps whose pixel centres have rays (renormalised; border pixels held within half a pixel of
/// the frame's edge); the rest keep `env`. Returns the map and its one-channel mask (`Y`: 1
/// where the view was pasted, else 0).
pub fn embed(env: &Image, view: &Image, lens: &Lens, rotation: Rotation) -> (Image, Image) {
    let (w, h, c) = (env.width, env.height, env.channels);
    let inverse = rotation.inverse().0;
    let mut out = env.clone();
    let mut mask = Image::new(w, h, 1);
    // Taps beyond the frame's border are held at it; a pixel with no ray carries nothing.
    let (vw, vh) = (view.width as isize - 1, view.height as isize - 1);
    let tap = |i: isize, j: isize| {
        let (i, j) = (i.clamp(0, vw) as usize, j.clamp(0, vh) as usize);
        lens.pixel_has_ray(i, j).then_some((i, j))
    };
    out.data.par_chunks_mut(w * c).zip(mask.data.par_chunks_mut(w)).enumerate().for_each(|(y, (row, mrow))| {
        let mut acc = vec![0.0; c];
        for x in 0..w {
            let d = DVec3::from(crate::geometry::latlong::texel_direction(x, y, w, h));
            let Some((px, py)) = lens.plane_of(inverse * d).filter(|&(px, py)| lens.in_frame(px, py)) else {
                continue;
            };
            let (fx, fy) = lens.pixel(px, py);
            if !bilinear::lookup(view, fx - 0.5, fy - 0.5, tap, &mut acc) {
                continue;
            }
            for (o, &a) in row[x * c..(x + 1) * c].iter_mut().zip(&acc) {
                *o = a as f32;
            }
            mrow[x] = 1.0;
        }
    });
    (out, mask)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::latlong;
    use crate::geometry::lens::Model;

    /// A 3-channel map whose texels hold their own centre directions.
    fn direction_map(w: usize, h: usize) -> Image {
        Image::from_fn_rgb(w, h, |x, y| latlong::texel_direction(x, y, w, h).map(|v| v as f32))
    }

    fn at(img: &Image, i: usize, j: usize) -> DVec3 {
        let p = img.pixel(i, j);
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    #[test]
    fn every_pixel_sees_its_ray() {
        let env = direction_map(512, 256);
        let r = Rotation::from_yaw_pitch_roll(30.0, -20.0, 10.0);
        for (model, fov) in [
            (Model::Perspective, 90.0),
            (Model::Fisheye, 360.0),
            (Model::Fisheye, 180.0),
            (Model::Orthographic, 180.0),
            (Model::Orthographic, 60.0),
        ] {
            let lens = Lens::new(model, fov, 33, 25).unwrap();
            for filter in Filter::ALL {
                let view = project(&env, &lens, r, filter);
                for j in 0..25 {
                    for i in 0..33 {
                        let got = at(&view, i, j);
                        let Some(ray) = lens.pixel_ray(i, j) else {
                            if filter == Filter::Bilinear {
                                assert_eq!(got, DVec3::ZERO, "{model} ({i}, {j})");
                            }
                            continue;
                        };
                        let want = r.apply(ray);
                        // Bilinear: the map's interpolation error (within half a row of a pole the
                        // row is held). Area: the mean direction over the pixel's footprint is the
                        // centre ray to the footprint's angular size squared.
                        let (x0, y0) = lens.plane(i as f64, j as f64 + 1.0);
                        let (x1, y1) = lens.plane(i as f64 + 1.0, j as f64);
                        let size = lens.rect_angle(x0, x1, y0, y1);
                        let whole = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].iter().all(|&(x, y)| lens.has_ray(x, y));
                        if filter == Filter::Area && !whole {
                            // The circle crosses the pixel: the mean over the part it covers.
                            assert!(got.length() <= 1.0 + 1e-6, "{model} ({i}, {j}): {got}");
                            continue;
                        }
                        let tol = match filter {
                            Filter::Bilinear if want.y.abs() > 0.999 => 2e-2,
                            Filter::Bilinear => 1e-3,
                            Filter::Area => 2e-3 + size * size,
                        };
                        assert!((got - want).length() < tol, "{model} {filter} ({i}, {j}): {got} vs {want}");
                    }
                }
            }
        }
    }

    #[test]
    fn yaw_90_looks_at_minus_x_as_rotate_does() {
        let env = direction_map(512, 256);
        let lens = Lens::new(Model::Perspective, 60.0, 33, 33).unwrap();
        let view = project(&env, &lens, Rotation::from_yaw_pitch_roll(90.0, 0.0, 0.0), Filter::Bilinear);
        assert!((at(&view, 16, 16) - DVec3::NEG_X).length() < 1e-4, "{}", at(&view, 16, 16));
        // Project of Rotate(env, R) at rest equals Project(env) rotated by R^T: a whole-column
        // yaw, so the same bilinear lookups shifted by W/4 columns.
        let noise = Image::from_vec(64, 32, 2, (0..64 * 32 * 2).map(|i| ((i * 7919) % 101) as f32).collect());
        let rotated =
            crate::maths::resample::rotation::rotate_latlong(&noise, Rotation::from_yaw_pitch_roll(90.0, 0.0, 0.0));
        let a = project(&rotated, &lens, Rotation::IDENTITY, Filter::Bilinear);
        let b = project(&noise, &lens, Rotation::from_yaw_pitch_roll(-90.0, 0.0, 0.0), Filter::Bilinear);
        let worst = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
    }

    #[test]
    fn a_bright_texel_lands_at_its_predicted_pixel_with_its_energy() {
        let (w, h) = (512, 256);
        let (x0, y0) = (300, 100);
        let mut env = Image::new(w, h, 1);
        env.data[y0 * w + x0] = 1000.0;
        let r = Rotation::from_yaw_pitch_roll(-15.0, 10.0, 5.0);
        let lens = Lens::new(Model::Perspective, 90.0, 64, 64).unwrap();
        let d = DVec3::from(latlong::texel_direction(x0, y0, w, h));
        let (px, py) = lens.plane_of(r.inverse().apply(d)).map(|(x, y)| lens.pixel(x, y)).unwrap();
        for filter in Filter::ALL {
            let view = project(&env, &lens, r, filter);
            let best = (0..64 * 64).max_by(|&a, &b| view.data[a].total_cmp(&view.data[b])).unwrap();
            let (bx, by) = ((best % 64) as f64 + 0.5, (best / 64) as f64 + 0.5);
            assert!((bx - px).abs() <= 1.0 && (by - py).abs() <= 1.0, "{filter}: ({bx}, {by}) vs ({px}, {py})");
        }
        // The Area view holds the texel's energy: its exact solid angle times 1000.
        let view = project(&env, &lens, r, Filter::Area);
        let energy: f64 = (0..64 * 64)
            .map(|k| {
                let (i, j) = ((k % 64) as f64, (k / 64) as f64);
                let (xa, ya) = lens.plane(i, j + 1.0);
                let (xb, yb) = lens.plane(i + 1.0, j);
                view.data[k] as f64 * lens.rect_solid_angle(xa, xb, ya, yb)
            })
            .sum();
        let (t0, t1) = (std::f64::consts::PI * y0 as f64 / h as f64, std::f64::consts::PI * (y0 + 1) as f64 / h as f64);
        let want = 1000.0 * 2.0 * std::f64::consts::PI / w as f64 * (t0.cos() - t1.cos());
        assert!((energy - want).abs() < 2e-5 * want, "{energy} vs {want}");
    }

    #[test]
    fn the_area_mean_of_a_constant_is_the_constant() {
        let env = Image::from_vec(64, 32, 1, vec![0.7; 64 * 32]);
        for (model, fov) in [(Model::Perspective, 120.0), (Model::Fisheye, 300.0), (Model::Orthographic, 180.0)] {
            let lens = Lens::new(model, fov, 40, 30).unwrap();
            let view = project(&env, &lens, Rotation::from_yaw_pitch_roll(10.0, 70.0, 0.0), Filter::Area);
            for j in 0..30 {
                for i in 0..40 {
                    let v = view.data[j * 40 + i];
                    let (x0, y0) = lens.plane(i as f64, j as f64 + 1.0);
                    let (x1, y1) = lens.plane(i as f64 + 1.0, j as f64);
                    let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
                    if lens.pixel_ray(i, j).is_some() {
                        assert_eq!(v, 0.7, "{model} ({i}, {j})");
                    } else if !corners.iter().any(|&(x, y)| lens.has_ray(x, y)) {
                        assert_eq!(v, 0.0, "{model} ({i}, {j}) has no ray");
                    } else {
                        assert!(v == 0.7 || v == 0.0, "{model} ({i}, {j}): {v}");
                    }
                }
            }
        }
    }

    /// `integral over [0, a] x [0, b] of dX dY / (1 + X^2 + Y^2)^2`: minus the z component of
    /// the integral of the direction over a perspective rectangle (the rectangle form factor).
    fn form_factor(a: f64, b: f64) -> f64 {
        let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
        0.5 * (a / sa * (b / sa).atan() + b / sb * (a / sb).atan())
    }

    #[test]
    fn the_area_view_keeps_the_mean_of_a_smooth_map_and_bilinear_is_close() {
        // L(d) = 1 + b.d: its integral over the frame is Omega + b.(R integral of c dOmega).
        let (w, h, b) = (1024, 512, DVec3::new(0.3, 0.5, -0.4));
        let env = Image::from_fn_rgb(w, h, |x, y| {
            [(1.0 + b.dot(DVec3::from(latlong::texel_direction(x, y, w, h)))) as f32; 3]
        });
        let r = Rotation::from_yaw_pitch_roll(25.0, 15.0, 0.0);
        let lens = Lens::new(Model::Perspective, 90.0, 64, 48).unwrap();
        let (t, hh) = (lens.half.tan(), lens.half_height());
        let omega = lens.rect_solid_angle(-1.0, 1.0, -hh, hh);
        let want = (omega + b.dot(r.apply(DVec3::new(0.0, 0.0, -4.0 * form_factor(t, t * hh))))) / omega;
        let mean = |view: &Image| -> f64 {
            let mut sum = 0.0;
            for k in 0..64 * 48 {
                let (i, j) = ((k % 64) as f64, (k / 64) as f64);
                let (xa, ya) = lens.plane(i, j + 1.0);
                let (xb, yb) = lens.plane(i + 1.0, j);
                sum += view.data[3 * k] as f64 * lens.rect_solid_angle(xa, xb, ya, yb);
            }
            sum / omega
        };
        let area = mean(&project(&env, &lens, r, Filter::Area));
        let bilinear = mean(&project(&env, &lens, r, Filter::Bilinear));
        assert!((area - want).abs() < 1e-5 * want, "area {area} vs {want}");
        // Measured: 6e-7 (Area) and 8e-7 (Bilinear, exact for a linear map up to the poles).
        assert!((bilinear - want).abs() < 1e-5 * want, "bilinear {bilinear} vs {want}");
    }

    #[test]
    fn embedding_a_projection_returns_the_map_inside_the_mask() {
        let (w, h) = (256, 128);
        let env = direction_map(w, h);
        let r = Rotation::from_yaw_pitch_roll(120.0, 30.0, -10.0);
        for (model, fov, covered) in [
            (Model::Perspective, 90.0, 2.0 * std::f64::consts::PI / 3.0),
            (Model::Fisheye, 200.0, 2.0 * std::f64::consts::PI * (1.0 - 100f64.to_radians().cos())),
        ] {
            let lens = Lens::new(model, fov, 256, 256).unwrap();
            let view = project(&env, &lens, r, Filter::Bilinear);
            let (back, mask) = embed(&Image::new(w, h, 3), &view, &lens, r);
            let mut solid = 0.0;
            for y in 0..h {
                for x in 0..w {
                    if mask.data[y * w + x] == 1.0 {
                        solid += latlong::texel_solid_angle(y, w, h);
                        let (a, b) = (at(&back, x, y), at(&env, x, y));
                        // Within two pixels of the fisheye's circle a lookup drops the taps
                        // beyond it (a nearest-pixel read, off by up to a pixel's angle).
                        let (px, py) = lens.plane_of(r.inverse().apply(b)).unwrap();
                        let rim = model == Model::Fisheye && (px * px + py * py).sqrt() > 1.0 - 4.0 / 256.0;
                        let tol = if b.y.abs() > 0.999 || rim { 3e-2 } else { 2e-3 };
                        assert!((a - b).length() < tol, "{model} ({x}, {y}): {a} vs {b}");
                    } else {
                        assert_eq!(at(&back, x, y), DVec3::ZERO);
                    }
                }
            }
            assert!((solid - covered).abs() < 0.02 * covered, "{model}: {solid} vs {covered}");
        }
    }
}
