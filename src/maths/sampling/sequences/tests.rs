//! Tests of the sample sequences: SplitMix64 against its reference outputs, stratification, Sobol
//! and Halton against their definitions, determinism.

use super::*;

const SEQS: [Sequence; 4] = Sequence::ALL;

#[test]
fn names_round_trip() {
    assert_eq!(NAMES.len(), Sequence::ALL.len());
    for (s, n) in Sequence::ALL.iter().zip(NAMES) {
        assert_eq!(s.name(), *n);
        assert_eq!(from_name(n), Some(*s));
        assert_eq!(from_name(&n.to_lowercase()), Some(*s));
    }
    assert_eq!(from_name("nope"), None);
}

#[test]
fn in_unit_square() {
    for seq in SEQS {
        for &n in &[0usize, 1, 2, 3, 4, 7, 16, 17, 100, 1000, 4096] {
            let pts = generate(seq, n, 42);
            assert_eq!(pts.len(), n);
            for p in &pts {
                for &c in p {
                    assert!((0.0..1.0).contains(&c), "{seq:?} {n}: {p:?}");
                }
            }
        }
    }
}

#[test]
fn deterministic_and_seeded() {
    for seq in SEQS {
        let a = generate(seq, 777, 5);
        let b = generate(seq, 777, 5);
        assert_eq!(a, b);
        let c = generate(seq, 777, 6);
        assert_ne!(a, c, "{seq:?} ignores its seed");
    }
}

#[test]
fn independent_of_thread_count() {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    for seq in SEQS {
        let one = pool.install(|| generate(seq, 5000, 9));
        let many = generate(seq, 5000, 9);
        assert_eq!(one, many, "{seq:?}");
    }
}

#[test]
fn stratified_square_one_point_per_cell() {
    for &k in &[1usize, 2, 4, 16] {
        let pts = generate(Sequence::Stratified, k * k, 3);
        let mut hits = vec![0u32; k * k];
        for p in &pts {
            let i = (p[0] * k as f64) as usize;
            let j = (p[1] * k as f64) as usize;
            hits[j * k + i] += 1;
        }
        assert!(hits.iter().all(|&h| h == 1), "k = {k}: {hits:?}");
    }
}

#[test]
fn stratified_latin_hypercube_one_point_per_row_and_column() {
    for &n in &[2usize, 3, 10, 99] {
        let pts = generate(Sequence::Stratified, n, 11);
        let mut cols = vec![0u32; n];
        let mut rows = vec![0u32; n];
        for p in &pts {
            cols[(p[0] * n as f64) as usize] += 1;
            rows[(p[1] * n as f64) as usize] += 1;
        }
        assert!(cols.iter().all(|&h| h == 1), "n = {n}");
        assert!(rows.iter().all(|&h| h == 1), "n = {n}");
    }
}

#[test]
fn sobol_byte_tables_match_the_bit_loop() {
    let v = sobol_dim1_matrix();
    let mut rng = SplitMix64::new(8);
    for k in 0..20_000u32 {
        let i = if k < 4096 { k } else { rng.next_u64() as u32 };
        let g = i ^ (i >> 1);
        let want = (0..32).filter(|b| g >> b & 1 == 1).fold(0u32, |acc, b| acc ^ v[b]);
        assert_eq!(sobol_2d_bits(i), [g.reverse_bits(), want], "index {i}");
    }
}

#[test]
fn sobol_first_points() {
    let expect = [[0.0, 0.0], [0.5, 0.5], [0.75, 0.25], [0.25, 0.75]];
    for (i, e) in expect.iter().enumerate() {
        assert_eq!(sobol_2d(i as u32), *e, "point {i}");
    }
    assert_eq!(&sobol_dim1_matrix()[..4], &[0x8000_0000, 0xC000_0000, 0xA000_0000, 0xF000_0000]);
}

/// Every aligned block of 2^m points is a (0, m, 2)-net: one point in every elementary
/// interval [a/2^p, (a+1)/2^p) x [b/2^q, (b+1)/2^q) with p + q = m. Owen scrambling keeps it.
#[test]
fn sobol_is_a_02_net_scrambled_and_not() {
    let m = 8u32;
    let n = 1usize << m;
    let scrambled = generate(Sequence::Sobol, 2 * n, 1234);
    let plain: Vec<[f64; 2]> = (0..2 * n as u32).map(sobol_2d).collect();
    for pts in [&scrambled[..n], &scrambled[n..], &plain[..n], &plain[n..]] {
        for p in 0..=m {
            let q = m - p;
            let mut hits = vec![0u32; n];
            for pt in pts {
                let a = (pt[0] * (1u64 << p) as f64) as usize;
                let b = (pt[1] * (1u64 << q) as f64) as usize;
                hits[(a << q) | b] += 1;
            }
            assert!(hits.iter().all(|&h| h == 1), "p = {p}, q = {q}");
        }
    }
}

#[test]
fn nested_scramble_is_a_bijection_on_prefixes() {
    // A nested permutation maps the top-k-bit prefix consistently: equal prefixes in,
    // equal prefixes out.
    let s = 0xDEAD_BEEF;
    for x in 0u32..1000 {
        let a = nested_uniform_scramble(x << 20, s);
        let b = nested_uniform_scramble((x << 20) | 0xFFFF, s);
        assert_eq!(a >> 20, b >> 20);
    }
}

#[test]
fn halton_unscrambled_matches_radical_inverse() {
    assert_eq!(radical_inverse(1, 2), 0.5);
    assert_eq!(radical_inverse(6, 2), 0.375);
    assert!((radical_inverse(1, 3) - 1.0 / 3.0).abs() < 1e-15);
    assert!((radical_inverse(5, 3) - (2.0 / 3.0 + 1.0 / 9.0)).abs() < 1e-15);
}

#[test]
fn halton_scrambled_stratifies() {
    // 2^3 * 3^2 = 72 points: one per cell of an 8 x 9 grid.
    let pts = generate(Sequence::Halton, 72, 77);
    let mut hits = vec![0u32; 72];
    for p in &pts {
        let i = (p[0] * 8.0) as usize;
        let j = (p[1] * 9.0) as usize;
        hits[j * 8 + i] += 1;
    }
    assert!(hits.iter().all(|&h| h == 1), "{hits:?}");
}

/// Discrepancy proxy: the mean of x*y over [0,1]^2 is 1/4; quasi-random points get closer.
#[test]
fn sobol_integrates_xy_better_than_random() {
    let n = 4096;
    let err = |seq: Sequence| {
        let pts = generate(seq, n, 2024);
        let mean = pts.iter().map(|p| p[0] * p[1]).sum::<f64>() / n as f64;
        (mean - 0.25).abs()
    };
    let sobol = err(Sequence::Sobol);
    let random = err(Sequence::Random);
    assert!(sobol < random, "sobol {sobol} vs random {random}");
    assert!(sobol < 1e-3, "{sobol}");
    let halton = err(Sequence::Halton);
    assert!(halton < 2e-3, "{halton}");
}

#[test]
fn splitmix_reference_values() {
    // Vigna's splitmix64.c seeded with 0: first output 0xE220A8397B1DCDAF.
    let mut r = SplitMix64::new(0);
    assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
    let mut r = SplitMix64::new(1);
    for _ in 0..10_000 {
        assert!(r.below(7) < 7);
        let f = r.next_f64();
        assert!((0.0..1.0).contains(&f));
    }
}

#[test]
fn isqrt_exact() {
    for n in 0..10_000usize {
        let k = isqrt(n);
        assert!(k * k <= n && (k + 1) * (k + 1) > n, "{n}");
    }
}
