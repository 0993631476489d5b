//! Tests of the sphere view and the relighting renderer: closed forms, orientation, merging,
//! culling and pinned bits.

use super::*;
use crate::geometry::latlong;
use crate::geometry::unit;
use std::f64::consts::PI;

/// Fibonacci-lattice directions: a low-discrepancy, equal-area set on the sphere
/// (Gonzalez 2010, "Measurement of areas on a sphere using Fibonacci and latitude-longitude
/// lattices"). Integrating max(n.w, 0) over 1024 of them errs by ~3e-4 (checked offline).
fn fibonacci(n: usize) -> Vec<[f32; 3]> {
    crate::geometry::fibonacci_sphere(n).iter().map(|d| d.map(|v| v as f32)).collect()
}

fn len(a: [f64; 3]) -> f64 {
    DVec3::from(a).length()
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    DVec3::from(a).dot(DVec3::from(b))
}

fn close3(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
}

/// Pixels spread over the disc: centre, near the rim, off-axis.
fn probe_pixels(size: usize) -> Vec<(usize, usize)> {
    let m = size / 2;
    vec![(m, m), (m, 1), (1, m), (size - 2, m), (m, size - 2), (size / 4, size / 3), (3 * size / 4, 2 * size / 3)]
}

#[test]
fn constant_environment_unbiased_gives_albedo() {
    let size = 33;
    let radiance = [1.0f32, 0.5, 2.0];
    let albedo = [0.8, 0.5, 0.3];
    let pdf = (1.0 / (4.0 * PI)) as f32;
    let dirs = fibonacci(1024);
    let lights: Vec<LightSample> = dirs.iter().map(|&d| LightSample::unbiased(d, radiance, pdf)).collect();
    for view_dir in [latlong::direction_deg(90.0, 90.0), [0.0, 0.0, 1.0], [0.3, 0.8, -0.52]] {
        let view = SphereView::new(size, view_dir);
        let img = relight(&view, &lights, Estimator::Unbiased.scale(albedo, lights.len(), 0.0));
        for (px, py) in probe_pixels(size) {
            assert!(view.normal_at(px, py).is_some());
            let p = img.pixel(px, py);
            for c in 0..3 {
                let want = albedo[c] * radiance[c] as f64;
                assert!(((p[c] as f64) - want).abs() < 0.01 * want, "({px},{py}) c{c}: {} vs {want}", p[c]);
            }
        }
    }
}

#[test]
fn constant_environment_seed_gives_albedo() {
    let size = 33;
    let rgb = [1.0f32, 0.5, 2.0];
    let m = (1.0f64 + 0.25 + 4.0).sqrt();
    let integral = 4.0 * PI * m; // int |rgb| dw over the sphere
    let albedo = [0.8, 0.5, 0.3];
    let lights: Vec<LightSample> = fibonacci(1024).iter().map(|&d| LightSample::seed(d, rgb)).collect();
    let view = SphereView::new(size, latlong::direction_deg(90.0, 90.0));
    let img = relight(&view, &lights, Estimator::Seed.scale(albedo, lights.len(), integral));
    for (px, py) in probe_pixels(size) {
        let p = img.pixel(px, py);
        for c in 0..3 {
            let want = albedo[c] * rgb[c] as f64;
            assert!(((p[c] as f64) - want).abs() < 0.01 * want, "({px},{py}) c{c}: {} vs {want}", p[c]);
        }
    }
}

/// Upper hemisphere at L, lower at 0: a L (1 + n_y) / 2 (NOTES.md, closed forms).
#[test]
fn upper_hemisphere_closed_form() {
    let size = 41;
    let a = 0.7;
    let pdf = (1.0 / (4.0 * PI)) as f32;
    let lights: Vec<LightSample> = fibonacci(4096)
        .iter()
        .map(|&d| LightSample::unbiased(d, if d[1] > 0.0 { [1.0; 3] } else { [0.0; 3] }, pdf))
        .collect();
    let view = SphereView::new(size, latlong::direction_deg(60.0, 30.0));
    let img = relight(&view, &lights, Estimator::Unbiased.scale([a; 3], lights.len(), 0.0));
    for py in 0..size {
        for px in 0..size {
            if let Some(n) = view.normal_at(px, py) {
                let want = a * (1.0 + n[1]) / 2.0;
                let got = img.pixel(px, py)[1] as f64;
                assert!((got - want).abs() < 3e-3, "({px},{py}) {got} vs {want}");
            }
        }
    }
}

#[test]
fn centre_normal_is_view_direction() {
    let d = latlong::direction_deg(90.0, 90.0);
    let view = SphereView::new(65, d);
    let n = view.normal_at(32, 32).unwrap();
    assert!(close3(n, d, 1e-12), "{n:?} vs {d:?}");
    assert!(close3(view.view_dir(), d, 1e-12));
}

#[test]
fn camera_at_plus_z_has_right_plus_x() {
    let view = SphereView::new(16, [0.0, 0.0, 1.0]);
    assert!(close3(view.right(), [1.0, 0.0, 0.0], 1e-15));
    assert!(close3(view.up(), [0.0, 1.0, 0.0], 1e-15));
    assert!(close3(view.forward(), [0.0, 0.0, -1.0], 1e-15));
    // The camera at -X (theta = phi = 90 degrees) sees +Z on its right.
    let side = SphereView::new(16, latlong::direction_deg(90.0, 90.0));
    assert!(close3(side.right(), [0.0, 0.0, 1.0], 1e-12), "{:?}", side.right());
}

#[test]
fn basis_is_orthonormal_including_poles() {
    for v in
        [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [1e-12, 1.0, 0.0], [0.0, 0.0, 0.0], [3.0, 4.0, 0.0], [f64::NAN, 0.0, 1.0]]
    {
        let view = SphereView::new(8, v);
        let (r, u, w) = (view.right(), view.up(), view.view_dir());
        for a in [r, u, w] {
            assert!((len(a) - 1.0).abs() < 1e-12, "{v:?}");
        }
        assert!(dot(r, u).abs() < 1e-12 && dot(r, w).abs() < 1e-12 && dot(u, w).abs() < 1e-12, "{v:?}");
        // right = forward x up
        assert!(close3(DVec3::from(view.forward()).cross(DVec3::from(u)).to_array(), r, 1e-12), "{v:?}");
    }
    let top = SphereView::new(8, [0.0, 1.0, 0.0]);
    assert!(close3(top.up(), [0.0, 0.0, -1.0], 1e-12));
    assert!(close3(top.right(), [1.0, 0.0, 0.0], 1e-12));
    let bottom = SphereView::new(8, [0.0, -1.0, 0.0]);
    assert!(close3(bottom.up(), [0.0, 0.0, 1.0], 1e-12));
    assert!(close3(bottom.right(), [1.0, 0.0, 0.0], 1e-12));
}

#[test]
fn normals_are_unit_and_face_the_camera() {
    let view = SphereView::new(32, latlong::direction_deg(70.0, 200.0));
    let mut on = 0;
    for py in 0..32 {
        for px in 0..32 {
            if let Some(n) = view.normal_at(px, py) {
                on += 1;
                assert!((len(n) - 1.0).abs() < 1e-12);
                assert!(dot(n, view.view_dir()) >= 0.0);
            }
        }
    }
    // The disc covers about pi/4 of the square.
    let frac = on as f64 / (32.0 * 32.0);
    assert!((frac - PI / 4.0).abs() < 0.03, "{frac}");
    assert!(view.normal_at(0, 0).is_none());
    assert!(SphereView::new(0, [0.0, 0.0, 1.0]).normal_at(0, 0).is_none());
}

#[test]
fn top_of_image_is_up() {
    let size = 64;
    let view = SphereView::new(size, latlong::direction_deg(90.0, 90.0));
    let top = view.normal_at(size / 2, 0).unwrap();
    assert!(top[1] > 0.9, "{top:?}");
    let bottom = view.normal_at(size / 2, size - 1).unwrap();
    assert!(bottom[1] < -0.9, "{bottom:?}");
    let right = view.normal_at(size - 1, size / 2).unwrap();
    assert!(right[2] > 0.9, "{right:?}");
}

#[test]
fn off_disc_pixels_are_exactly_zero() {
    let size = 48;
    let lights: Vec<LightSample> =
        fibonacci(100).iter().map(|&d| LightSample { dir: d, weight: [5.0, 6.0, 7.0] }).collect();
    let view = SphereView::new(size, [0.2, 0.3, 0.9]);
    let img = relight(&view, &lights, [1.0, 1.0, 1.0]);
    assert_eq!((img.width, img.height, img.channels), (size, size, 3));
    let mut lit = 0;
    for py in 0..size {
        for px in 0..size {
            if view.normal_at(px, py).is_none() {
                assert_eq!(img.pixel(px, py), &[0.0f32; 3][..], "({px},{py})");
            } else if img.pixel(px, py)[0] > 0.0 {
                lit += 1;
            }
        }
    }
    assert!(lit > 0);
    assert_eq!(img.pixel(0, 0), &[0.0f32; 3][..]);
    assert_eq!(img.pixel(size - 1, size - 1), &[0.0f32; 3][..]);
}

#[test]
fn back_facing_light_adds_nothing_front_light_is_cosine() {
    let size = 65;
    let view = SphereView::new(size, [0.0, 0.0, 1.0]);
    let behind = [LightSample { dir: [0.0, 0.0, -1.0], weight: [1.0; 3] }];
    let img = relight(&view, &behind, [1.0; 3]);
    assert!(img.data.iter().all(|&v| v == 0.0));

    let front = [LightSample { dir: [0.0, 0.0, 1.0], weight: [2.0, 3.0, 4.0] }];
    let img = relight(&view, &front, [0.5, 0.5, 0.5]);
    assert_eq!(img.pixel(32, 32), &[1.0f32, 1.5, 2.0][..]);
    for py in 0..size {
        for px in 0..size {
            if let Some(n) = view.normal_at(px, py) {
                let want = 0.5 * 2.0 * n[2];
                assert!((img.pixel(px, py)[0] as f64 - want).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn merged_duplicates_render_the_same() {
    let dirs = fibonacci(10);
    let mk = |i: usize, w: f32| (i as u32, LightSample { dir: dirs[i], weight: [w, 2.0 * w, 0.5] });
    let samples = vec![mk(3, 1.0), mk(7, 2.0), mk(3, 1.0), mk(3, 1.0), mk(1, 0.25), mk(7, 2.0)];
    let merged = merge_duplicates(&samples);
    assert_eq!(merged.len(), 3);
    assert_eq!(merged[0].dir, dirs[3]);
    assert_eq!(merged[0].weight, [3.0, 6.0, 1.5]);
    assert_eq!(merged[1].weight, [4.0, 8.0, 1.0]);
    assert_eq!(merged[2].weight, [0.25, 0.5, 0.5]);

    let all: Vec<LightSample> = samples.iter().map(|s| s.1).collect();
    let view = SphereView::new(40, [0.1, 0.2, 0.97]);
    let a = relight(&view, &all, [0.3, 0.4, 0.5]);
    let b = relight(&view, &merged, [0.3, 0.4, 0.5]);
    for (x, y) in a.data.iter().zip(&b.data) {
        assert!((x - y).abs() <= 1e-6 * x.abs().max(1.0), "{x} {y}");
    }
    assert!(merge_duplicates(&[]).is_empty());
}

#[test]
fn light_constructors() {
    let l = LightSample::unbiased([0.0, 1.0, 0.0], [1.0, 2.0, 3.0], 0.5);
    assert_eq!(l.weight, [2.0, 4.0, 6.0]);
    assert_eq!(LightSample::unbiased([0.0, 1.0, 0.0], [1.0; 3], 0.0).weight, [0.0; 3]);
    assert_eq!(LightSample::unbiased([0.0, 1.0, 0.0], [1.0; 3], f32::NAN).weight, [0.0; 3]);
    let s = LightSample::seed([0.0, 1.0, 0.0], [3.0, 0.0, 4.0]);
    assert_eq!(s.weight, [0.6, 0.0, 0.8]);
    assert_eq!(LightSample::seed([0.0, 1.0, 0.0], [0.0; 3]).weight, [0.0; 3]);
    assert_eq!(Estimator::Unbiased.scale([1.0; 3], 0, 1.0), [0.0; 3]);
    let k = Estimator::Seed.scale([PI; 3], 4, 8.0);
    assert!((k[0] - 2.0).abs() < 1e-6);
}

#[test]
fn no_lights_or_zero_size() {
    let view = SphereView::new(8, [0.0, 0.0, 1.0]);
    let img = relight(&view, &[], [1.0; 3]);
    assert_eq!(img.data.len(), 8 * 8 * 3);
    assert!(img.data.iter().all(|&v| v == 0.0));
    let empty = relight(&SphereView::new(0, [0.0, 0.0, 1.0]), &[], [1.0; 3]);
    assert_eq!((empty.width, empty.height, empty.data.len()), (0, 0, 0));
}

/// A small deterministic generator (xorshift64*), uniform in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A unit direction uniform on the sphere.
    fn dir(&mut self) -> [f64; 3] {
        let z = 1.0 - 2.0 * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * self.next();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

/// A mix of a tight "sun" cluster and scattered sky lights, weights spanning 5 decades.
fn mixed_lights(n: usize) -> Vec<LightSample> {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let sun = unit(DVec3::new(0.4, 0.7, -0.6)).unwrap();
    (0..n)
        .map(|i| {
            let d = if i % 3 == 0 {
                let j = DVec3::from(rng.dir());
                unit(sun + 0.02 * j).unwrap().to_array()
            } else {
                rng.dir()
            };
            let w = if i % 3 == 0 { 1e4 } else { 0.1 + rng.next() };
            LightSample {
                dir: [d[0] as f32, d[1] as f32, d[2] as f32],
                weight: [w as f32, (0.5 * w) as f32, (0.25 * w * rng.next()) as f32],
            }
        })
        .collect()
}

#[test]
fn kernels_agree_bit_for_bit() {
    let lights = mixed_lights(1001);
    let view = SphereView::new(50, [0.3, 0.5, 0.81]);
    let scale = [0.01, 0.02, 0.03];
    let reference = relight_with(Kernel::Scalar, &view, &lights, scale);
    assert!(reference.data.iter().any(|&v| v > 0.0));
    for level in crate::cpu::tested_levels() {
        let img = relight_with(Kernel::at(level), &view, &lights, scale);
        assert!(img.data.iter().zip(&reference.data).all(|(a, b)| a.to_bits() == b.to_bits()), "{level}");
    }
    assert_eq!(relight(&view, &lights, scale).data, reference.data);
}

/// RelightSphere's output bits, pinned: BLAKE3 of two renders, computed with the code before
/// the kernels were shared with ReferenceSphere (commit 3aa044f). The inputs use only `+ - * /`
/// and `sqrt` (correctly rounded in IEEE 754), so inputs and hashes are the same on every
/// platform, and every kernel must reproduce them. A change here means RelightSphere's
/// renders changed: say so in the commit and bump the operator's version.
#[test]
fn render_bits_are_pinned() {
    let mut rng = crate::maths::sampling::sequences::SplitMix64::new(2024);
    let lights: Vec<LightSample> = (0..700)
        .map(|i| {
            let v = DVec3::new(2.0 * rng.next_f64() - 1.0, 2.0 * rng.next_f64() - 1.0, 2.0 * rng.next_f64() - 1.0);
            let d = v / v.length();
            let w = if i % 4 == 0 { 1e4 * rng.next_f64() } else { rng.next_f64() };
            LightSample { dir: d.as_vec3().to_array(), weight: [w as f32, (0.5 * w) as f32, (0.25 * w) as f32] }
        })
        .collect();
    let pinned = [
        ([0.3, 0.5, -0.81], 67usize, "0ddde302d414668b2da69eee7fb785a6280de58a9f64cf7403625672d1b05f18"),
        ([0.0, 1.0, 0.0], 40, "65d39a8568616c4d4a6803d023f184f0b8d3086b24543dd0d68b3458a0ed8aed"),
    ];
    #[allow(unused_mut)]
    let mut kernels = vec![Kernel::Scalar];
    #[cfg(target_arch = "x86_64")]
    kernels.extend([Kernel::Sse2, Kernel::Avx, Kernel::Avx512]); // each falls back to what the CPU has
    for (view_dir, size, hash) in pinned {
        for &kernel in &kernels {
            let img = relight_with(kernel, &SphereView::new(size, view_dir), &lights, [0.01, 0.02, 0.03]);
            let bytes: Vec<u8> = img.data.iter().flat_map(|v| v.to_le_bytes()).collect();
            assert_eq!(blake3::hash(&bytes).to_hex().as_str(), hash, "{kernel:?} {view_dir:?} {size}");
        }
    }
}

/// Tile culling changes nothing beyond f32 rounding: compare with a brute-force f64 sum over
/// every light at every pixel (views where the sun is in front, behind and at the limb).
#[test]
fn culled_render_matches_f64_brute_force() {
    let lights = mixed_lights(600);
    let scale = [1.0f32, 1.0, 1.0];
    for view_dir in [[0.4, 0.7, -0.6], [-0.4, -0.7, 0.6], [0.6, 0.0, 0.4], [0.0, 0.0, 1.0]] {
        let view = SphereView::new(70, view_dir);
        let img = relight(&view, &lights, scale);
        for py in 0..70 {
            for px in 0..70 {
                let Some(n) = view.normal_at(px, py) else {
                    assert_eq!(img.pixel(px, py), &[0.0f32; 3][..]);
                    continue;
                };
                let nf = [n[0] as f32 as f64, n[1] as f32 as f64, n[2] as f32 as f64];
                let mut want = [0.0f64; 3];
                let mut mag = 0.0f64;
                for l in &lights {
                    let d = [l.dir[0] as f64, l.dir[1] as f64, l.dir[2] as f64];
                    let c = dot(nf, d).max(0.0);
                    for (w, lw) in want.iter_mut().zip(l.weight) {
                        *w += c * lw as f64;
                    }
                    mag += dot(nf, d).abs() * l.weight[0] as f64;
                }
                for (ch, want_ch) in want.iter().enumerate() {
                    let got = img.pixel(px, py)[ch] as f64;
                    assert!(
                        (got - want_ch).abs() <= 1e-5 * mag + 1e-9,
                        "{view_dir:?} ({px},{py}) ch{ch}: {got} vs {want_ch}"
                    );
                }
            }
        }
    }
}
