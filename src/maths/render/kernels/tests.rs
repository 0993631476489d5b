//! Tests of the cosine-sum kernels: every instruction-set path against the portable one bit for
//! bit, and the cull margin (culled pairs contribute exactly zero).

use super::*;
use crate::maths::sampling::sequences::SplitMix64;

fn random_unit(rng: &mut SplitMix64) -> DVec3 {
    let z = 1.0 - 2.0 * rng.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * std::f64::consts::PI * rng.next_f64()).sin_cos();
    DVec3::new(r * c, r * s, z)
}

fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

/// The scalar loop, then the kernel of every level the CPU has.
fn kernels() -> Vec<Kernel> {
    let mut all = vec![Kernel::Scalar];
    all.extend(cpu::tested_levels().into_iter().map(Kernel::at));
    all
}

fn sums(kernel: Kernel, blocks: &[Block], normals: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let mut out = vec![[f32::NAN; 3]; normals.len()];
    kernel.for_each_sum(blocks, normals, |i, s| out[i] = s);
    out
}

#[test]
fn kernels_agree_bit_for_bit_including_edge_lanes() {
    let mut rng = SplitMix64::new(42);
    let mut lights: Vec<([f32; 3], [f32; 3])> = (0..203)
        .map(|i| {
            let w = if i % 7 == 0 { 1e5 * rng.next_f64() } else { rng.next_f64() };
            (f32x3(random_unit(&mut rng)), [w as f32, (0.3 * w) as f32, -(0.1 * w) as f32])
        })
        .collect();
    // A light exactly at 90 degrees from +Z, a -0 direction, a negative zero weight.
    lights.push(([1.0, 0.0, 0.0], [1.0; 3]));
    lights.push(([-0.0, -0.0, -0.0], [5.0; 3]));
    lights.push(([0.0, 0.0, 1.0], [-0.0; 3]));
    let mut blocks = Vec::new();
    pack_blocks(lights.iter().copied(), &mut blocks);
    assert_eq!(blocks.len(), lights.len().div_ceil(LANES));
    let mut normals: Vec<[f32; 3]> = (0..37).map(|_| f32x3(random_unit(&mut rng))).collect();
    normals.extend([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [f32::NAN, 0.0, 1.0]]);
    let reference = sums(Kernel::Scalar, &blocks, &normals);
    assert!(reference.iter().any(|s| s[0] > 0.0));
    for kernel in kernels() {
        for count in [normals.len(), normals.len() - 1, 1, 0] {
            let got = sums(kernel, &blocks, &normals[..count]);
            for (g, r) in got.iter().zip(&reference) {
                assert_eq!(g.map(f32::to_bits), r.map(f32::to_bits), "{kernel:?} with {count} normals");
            }
        }
    }
}

#[test]
fn scalar_kernel_is_the_documented_sum() {
    let lights = [([0.6f32, 0.0, 0.8], [1.0f32, 2.0, 3.0]), ([0.0, 0.0, -1.0], [7.0; 3])];
    let mut blocks = Vec::new();
    pack_blocks(lights, &mut blocks);
    let s = sums(Kernel::Scalar, &blocks, &[[0.0, 0.0, 1.0]]);
    assert_eq!(s[0], [0.8, 1.6, 0.8 * 3.0]);
    assert!(sums(Kernel::Scalar, &[], &[[0.0, 0.0, 1.0]])[0] == [0.0; 3]);
}

#[test]
fn cone_bounds_its_directions() {
    assert!(Cone::around(std::iter::empty()).is_none());
    assert!(Cone::around([DVec3::X, -DVec3::X].into_iter()).is_none());
    assert!(Cone::around([DVec3::X, DVec3::Y].into_iter()).is_some());
    assert!(Cone::around([DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X].into_iter()).is_none());
    assert!(Cone::around([DVec3::X, DVec3::new(f64::NAN, 0.0, 0.0)].into_iter()).is_none());
    let one = Cone::around([DVec3::Z].into_iter()).unwrap();
    assert_eq!((one.axis, one.cos, one.sin), (DVec3::Z, 1.0, 0.0));
    // For a single light, the threshold is exactly -(sin t + M).
    let c = Cone { axis: DVec3::Z, cos: 0.8, sin: 0.6 };
    assert_eq!(c.cull_threshold(Cone::RAY), Some(-(0.6 + CULL_MARGIN)));
    // Cones of 50 + 45 degrees cannot be culled against each other.
    let (c50, c45) = (50f64.to_radians(), 45f64.to_radians());
    let wide = Cone { axis: DVec3::Z, cos: c50.cos(), sin: c50.sin() };
    assert!(wide.cull_threshold((c45.cos(), c45.sin())).is_none());
}

/// The margin at work: normals on the rim of a cone, lights on the rim of another, their
/// axes as close as the test allows (`cos gamma` at the threshold, and a few ulps either
/// side), and of each pair the closest normal and light. Whenever the test culls, every f32
/// term must be exactly +0: checked with `CULL_MARGIN` and with 4e-7, just above the derived
/// minimum (~3.5e-7). Without a margin the same construction does let f32 terms through,
/// which is why one is needed. Half-angles from 0 to ~80 degrees, many orientations.
#[test]
fn culled_pairs_contribute_exactly_zero() {
    let kernels = kernels();
    for (margin, must_be_safe) in [(CULL_MARGIN, true), (4e-7, true), (0.0, false)] {
        let mut rng = SplitMix64::new(7);
        let (mut culled, mut leaked) = (0usize, 0usize);
        for case in 0..4000 {
            let t = if case % 4 == 0 { 0.0 } else { 1.4 * rng.next_f64().powi(3) };
            let b = if case % 3 == 0 { 0.0 } else { 1.4 * rng.next_f64().powi(3) };
            let c = random_unit(&mut rng);
            let p = unit(c.cross(random_unit(&mut rng))).unwrap(); // orthogonal to c
            if t + b >= 0.5 * std::f64::consts::PI {
                continue;
            }
            let normals = Cone { axis: c, cos: t.cos(), sin: t.sin() };
            let h = normals.threshold_with_margin((b.cos(), b.sin()), margin).unwrap();
            let gamma = h.clamp(-1.0, 1.0).acos();
            for ulps in [-2i64, 0, 2] {
                let g = f64::from_bits((gamma.to_bits() as i64 + ulps) as u64);
                let a = c * g.cos() + p * g.sin();
                let lights = Cone { axis: a, cos: b.cos(), sin: b.sin() };
                let hides =
                    normals.threshold_with_margin((lights.cos, lights.sin), margin).is_some_and(|h| c.dot(a) <= h);
                if !hides {
                    continue;
                }
                culled += 1;
                // The closest pair: the normal tilted by t towards a, the light by b towards c.
                let n = c * t.cos() + p * t.sin();
                let q = unit(a.cross(c).cross(a)).unwrap_or(c); // orthogonal to a, towards c
                let d = a * b.cos() + q * b.sin();
                let mut blocks = Vec::new();
                pack_blocks([(f32x3(d), [1.0; 3])], &mut blocks);
                for &kernel in &kernels {
                    let s = sums(kernel, &blocks, &[f32x3(n)]);
                    if s[0] != [0.0; 3] || s[0][0].is_sign_negative() {
                        leaked += 1;
                        assert!(!must_be_safe, "margin {margin}, t {t} b {b}: n.d = {}", n.dot(d));
                    }
                }
            }
        }
        assert!(culled > 3000, "margin {margin}: {culled} culled");
        if !must_be_safe {
            assert!(leaked > 0, "without a margin some culled pairs should have a positive f32 dot");
        }
    }
}
