//! Tests of the hierarchical warp: texel probabilities against the distribution, the rounding
//! bound, and the SIMD descent against the portable one bit for bit.

use super::*;
use crate::maths::sampling::sequences::SplitMix64;
use crate::values::Image;

fn maps() -> Vec<Image> {
    let mut rng = SplitMix64::new(3);
    let map = |w: usize, h: usize, f: &mut dyn FnMut(usize, usize) -> f32| {
        let data = (0..w * h).map(|i| f(i % w, i / w)).collect();
        Image::from_vec(w, h, 1, data)
    };
    vec![
        map(37, 19, &mut |x, y| if y % 3 == 0 || x % 5 == 1 { 0.0 } else { (x * y) as f32 }),
        map(64, 32, &mut |x, y| if (x, y) == (40, 10) { 1e6 } else { 1e-3 }),
        map(16, 8, &mut |x, _| if x < 15 { 0.0 } else { 1.0 }),
        map(128, 64, &mut |_, _| rng.next_f64() as f32 * 10.0),
        map(32, 16, &mut |_, _| 0.0),
        map(8, 32, &mut |x, y| (x + y) as f32),
        map(1, 1, &mut |_, _| 2.0),
        map(5, 1, &mut |x, _| x as f32),
    ]
}

/// The descent's texel probabilities equal the distribution's to the f32 bound of the
/// module documentation, and zero-probability texels (padding included) are never drawn.
#[test]
fn probabilities_match_the_distribution() {
    let mut rng = SplitMix64::new(9);
    for map in maps() {
        let dist = Distribution2D::build(&map, true, false).unwrap();
        let warp = HierarchicalWarp::new(&dist);
        let bound = (warp.level_count() + 1) as f64 * 2f64.powi(-24) * 1.5;
        let mut total = 0.0;
        for y in 0..map.height {
            for x in 0..map.width {
                let (p, q) = (dist.texel_probability(x, y), warp.texel_probability(x, y));
                total += q;
                if p == 0.0 {
                    assert_eq!(q, 0.0);
                } else {
                    assert!((q / p - 1.0).abs() <= bound, "{}x{} ({x}, {y}): {q} vs {p}", map.width, map.height);
                }
            }
        }
        assert!((total - 1.0).abs() < 1e-6, "{total}");
        let mut us: Vec<f64> = vec![0.0, -0.0, 1.0, 0.5, 1.0 - 1e-17, f64::NAN];
        for _ in 0..20_000 {
            us.push(rng.next_f64());
        }
        for (i, &u1) in us.iter().enumerate() {
            let u2 = us[(i * 7 + 3) % us.len()];
            let (x, y, rx, ry) = warp.sample(u1, u2);
            assert!(x < map.width && y < map.height);
            assert!(dist.texel_probability(x, y) > 0.0, "({x}, {y}) drawn with probability 0");
            assert!((0.0..1.0).contains(&rx) && (0.0..1.0).contains(&ry), "{rx} {ry}");
        }
    }
}

/// The batch descent, at every level the processor has (AVX-512: eight draws at a time),
/// gives the scalar steps' bits.
#[test]
fn batch_descent_matches_the_scalar_steps() {
    let levels = cpu::tested_levels();
    let mut rng = SplitMix64::new(23);
    for map in maps() {
        let dist = Distribution2D::build(&map, true, false).unwrap();
        let warp = HierarchicalWarp::new(&dist);
        for _ in 0..500 {
            let mut batch: Vec<WarpDraw> = (0..19).map(|_| warp.start(rng.next_f64(), rng.next_f64())).collect();
            batch[3] = warp.start(0.0, 1.0);
            batch[5] = warp.start(1.0, 0.0);
            batch[9] = warp.start(-0.0, -0.0);
            let mut scalar = batch.clone();
            for draw in &mut scalar {
                for level in (0..warp.levels.len()).rev() {
                    warp.step(level, draw);
                }
            }
            for &cpu_level in &levels {
                let mut descended = batch.clone();
                warp.descend_at(cpu_level, &mut descended);
                for (a, b) in descended.iter().zip(&scalar) {
                    assert_eq!(
                        (a.x, a.y, a.ux.to_bits(), a.uy.to_bits()),
                        (b.x, b.y, b.ux.to_bits(), b.uy.to_bits()),
                        "{cpu_level}"
                    );
                }
            }
        }
    }
}

/// A draw descended twice would index past the top levels: refused with a panic.
#[test]
#[should_panic(expected = "fresh from start")]
fn descending_twice_is_refused() {
    let map = Image::from_vec(64, 32, 1, (0..2048).map(|i| (i % 13) as f32).collect());
    let dist = Distribution2D::build(&map, true, false).unwrap();
    let warp = HierarchicalWarp::new(&dist);
    let mut draws = [warp.start(0.9, 0.9); 8];
    warp.descend(&mut draws);
    warp.descend(&mut draws);
}

/// Frequencies of 4M random draws match the probabilities (within 5 sigma), and the
/// remainders are uniform inside each texel (their means within 5 sigma of 1/2): the warp is
/// measure preserving, the property the estimator relies on.
#[test]
fn draws_reproduce_the_probabilities() {
    let map = Image::from_vec(16, 8, 1, (0..128).map(|i| ((i * 37) % 11) as f32 + 0.5).collect());
    let dist = Distribution2D::build(&map, true, false).unwrap();
    let warp = HierarchicalWarp::new(&dist);
    let n = 1 << 22;
    let mut rng = SplitMix64::new(17);
    let mut counts = vec![0usize; 128];
    let mut mean_r = vec![[0.0f64; 2]; 128];
    for _ in 0..n {
        let (x, y, rx, ry) = warp.sample(rng.next_f64(), rng.next_f64());
        counts[y * 16 + x] += 1;
        mean_r[y * 16 + x][0] += rx;
        mean_r[y * 16 + x][1] += ry;
    }
    for y in 0..8 {
        for x in 0..16 {
            let k = y * 16 + x;
            let p = warp.texel_probability(x, y);
            let expected = p * n as f64;
            assert!((counts[k] as f64 - expected).abs() <= 5.0 * expected.sqrt() + 5.0, "({x}, {y})");
            // A uniform remainder's mean has standard deviation sqrt(1/12 / count).
            let (c, sigma) = (counts[k] as f64, (1.0 / 12.0 / counts[k] as f64).sqrt());
            let (mx, my) = (mean_r[k][0] / c, mean_r[k][1] / c);
            assert!((mx - 0.5).abs() < 5.0 * sigma && (my - 0.5).abs() < 5.0 * sigma, "({x}, {y}): {mx} {my}");
        }
    }
}
