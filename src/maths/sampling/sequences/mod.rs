//! 2D point sequences in [0, 1)^2 that drive the samplers: independent random, stratified,
//! Owen-scrambled Sobol and scrambled Halton.
//!
//! Everything here is deterministic for a given `(sequence, count, seed)`, independent of the
//! number of rayon threads: the random numbers come from a self-contained SplitMix64 generator
//! (no dependency on `rand`'s API or its stream stability across versions), and the
//! low-discrepancy points are pure functions of their index.
//!
//! Sources:
//! - SplitMix64: G. Steele, D. Lea, C. Flood, "Fast Splittable Pseudorandom Number Generators",
//!   OOPSLA 2014; constants as in S. Vigna's public-domain `splitmix64.c`.
//! - Bounded integers: D. Lemire, "Fast Random Integer Generation in an Interval", ACM TOMACS 2019.
//! - Sobol: I. M. Sobol' 1967; P. Bratley, B. L. Fox, "Algorithm 659", ACM TOMS 1988 (direction
//!   numbers, Gray-code order of Antonov and Saleev 1979); S. Joe, F. Y. Kuo 2008 (dimension 2:
//!   m = 1, 3, 5, 15, ...).
//! - Owen scrambling: A. B. Owen 1995; S. Laine, T. Karras, "Stratified Sampling for Stochastic
//!   Transparency", EGSR 2011 (hash permutation); B. Burley, "Practical Hash-based Owen
//!   Scrambling", JCGT 9(4), 2020 (nested uniform scramble = reverse bits, LK hash, reverse bits).
//! - Halton with random digit permutations: J. H. Halton 1960; pbrt-v3 `ScrambledRadicalInverse`
//!   (Pharr, Jakob, Humphreys, *Physically Based Rendering* 3rd ed., section 7.4.2).

use rayon::prelude::*;

/// The largest f64 below 1: 1 - 2^-53.
const ONE_MINUS_EPSILON: f64 = 1.0 - f64::EPSILON / 2.0;

crate::choice! {
    /// The point sequences `generate` knows.
    pub enum Sequence {
        /// Independent uniform points (SplitMix64).
        Random,
        /// Jittered k x k grid when the count is a perfect square, else Latin hypercube (N-rooks).
        Stratified,
        /// The 2D Sobol (0,2)-sequence, Owen-scrambled (Burley 2020).
        Sobol,
        /// Halton, bases 2 and 3, with seeded random digit permutations.
        Halton,
    }
}

/// The names of the sequences, in declaration order (as written in pipeline files).
pub const NAMES: &[&str] = Sequence::NAMES;

/// The sequence called `name` (case-insensitive), or `None`.
pub fn from_name(name: &str) -> Option<Sequence> {
    Sequence::from_name_ignore_case(name)
}

// ---------------------------------------------------------------------------------------------
// SplitMix64
// ---------------------------------------------------------------------------------------------

/// The SplitMix64 finaliser (a bijective 64-bit mix):
/// `z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9; z = (z ^ (z >> 27)) * 0x94D049BB133111EB;
/// z ^ (z >> 31)` (Steele, Lea, Flood 2014; Vigna's `splitmix64.c`).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// SplitMix64's increment: the golden ratio in 0.64 fixed point (Steele, Lea, Flood 2014).
pub const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// A 64-bit draw to a uniform in [0, 1): its top 53 bits times 2^-53 (exact).
#[inline(always)]
pub fn unit_f64(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A tiny, fully deterministic 64-bit generator: state += 0x9E3779B97F4A7C15 (the golden
/// ratio in 0.64 fixed point), output `mix64(state)`. Period 2^64; passes BigCrush
/// (Steele, Lea, Flood 2014). Used instead of `rand` so streams never change with a dependency.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN_GAMMA);
        mix64(self.state)
    }

    /// Uniform in [0, 1): the top 53 bits times 2^-53 (every value a multiple of 2^-53).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        unit_f64(self.next_u64())
    }

    /// What the `k`-th next call of `next_u64` will return (`k = 0`: the next), without
    /// advancing. The state is a counter, so every output is one addition and one [`mix64`]
    /// away: a batch of draws can be computed side by side (in SIMD lanes).
    #[inline(always)]
    pub fn peek(&self, k: u64) -> u64 {
        mix64(self.state.wrapping_add(k.wrapping_add(1).wrapping_mul(GOLDEN_GAMMA)))
    }

    /// Advances as `k` calls of `next_u64` would.
    #[inline]
    pub fn skip(&mut self, k: u64) {
        self.state = self.state.wrapping_add(k.wrapping_mul(GOLDEN_GAMMA));
    }

    /// Uniform integer in [0, n) without modulo bias (Lemire 2019: multiply, keep the high
    /// word, reject when the low word is below 2^64 mod n). `n == 0` returns 0.
    pub fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            return 0;
        }
        let mut m = (self.next_u64() as u128) * (n as u128);
        let mut low = m as u64;
        if low < n {
            let threshold = n.wrapping_neg() % n;
            while low < threshold {
                m = (self.next_u64() as u128) * (n as u128);
                low = m as u64;
            }
        }
        (m >> 64) as u64
    }
}

// ---------------------------------------------------------------------------------------------
// Generation
// ---------------------------------------------------------------------------------------------

/// `count` points of sequence `seq` in [0, 1)^2, deterministic for `(seq, count, seed)`
/// whatever the number of threads.
///
/// - `Random`: independent points from `SplitMix64::new(seed)` (x then y for each point).
/// - `Stratified`: if `count = k^2`, a jittered grid: point `(i, j)` (row-major, j outer) is
///   `((i + u) / k, (j + v) / k)` with u, v uniform in [0, 1) — exactly one point per cell.
///   Otherwise a Latin hypercube (N-rooks, McKay, Beckman, Conover 1979): point i is
///   `((i + u) / N, (pi(i) + v) / N)` for one seeded random permutation pi (Fisher-Yates) —
///   exactly one point in each of the N columns and each of the N rows. Points are not shuffled.
/// - `Sobol`: `sobol_2d` (Gray-code order) with each dimension Owen-scrambled by Burley's
///   hash-based nested uniform scramble with seeds derived from `seed`. The index is not
///   shuffled, so every aligned block of 2^m points is a (0, m, 2)-net. Indices wrap at 2^32.
/// - `Halton`: radical inverses in bases 2 and 3, each digit passed through a random
///   permutation of {0..b-1} drawn per digit position from `seed` (random digit scrambling, as
///   pbrt-v3's `ScrambledRadicalInverse`; not a Cranley-Patterson rotation). Index starts at 0.
///
/// All coordinates are clamped to at most 1 - 2^-53 so that none rounds to 1.0.
pub fn generate(seq: Sequence, count: usize, seed: u64) -> Vec<[f64; 2]> {
    match seq {
        Sequence::Random => {
            let mut rng = SplitMix64::new(seed);
            (0..count).map(|_| [rng.next_f64(), rng.next_f64()]).collect()
        }
        Sequence::Stratified => stratified(count, seed),
        Sequence::Sobol => {
            let (s0, s1) = sobol_seeds(seed);
            (0..count)
                .into_par_iter()
                .map(|i| {
                    let [x, y] = sobol_2d_bits(i as u32);
                    [bits_to_unit(nested_uniform_scramble(x, s0)), bits_to_unit(nested_uniform_scramble(y, s1))]
                })
                .collect()
        }
        Sequence::Halton => {
            let perms2 = digit_permutations(2, HALTON_DIGITS_BASE2, mix64(seed ^ 0x4841_4C54_4F4E_0002));
            let perms3 = digit_permutations(3, HALTON_DIGITS_BASE3, mix64(seed ^ 0x4841_4C54_4F4E_0003));
            (0..count)
                .into_par_iter()
                .map(|i| {
                    [scrambled_radical_inverse(i as u64, 2, &perms2), scrambled_radical_inverse(i as u64, 3, &perms3)]
                })
                .collect()
        }
    }
}

/// Integer square root (floor), exact for all usize.
fn isqrt(n: usize) -> usize {
    let mut k = (n as f64).sqrt() as usize;
    while k > 0 && k.checked_mul(k).is_none_or(|s| s > n) {
        k -= 1;
    }
    while (k + 1).checked_mul(k + 1).is_some_and(|s| s <= n) {
        k += 1;
    }
    k
}

/// `(cell + jitter) / strata`, kept below 1 (for k > 1 the sum can round up to k).
#[inline]
fn stratum_point(cell: usize, jitter: f64, strata: usize) -> f64 {
    ((cell as f64 + jitter) / strata as f64).min(ONE_MINUS_EPSILON)
}

fn stratified(count: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = SplitMix64::new(seed);
    let k = isqrt(count);
    if k * k == count {
        let mut pts = Vec::with_capacity(count);
        for j in 0..k {
            for i in 0..k {
                let u = rng.next_f64();
                let v = rng.next_f64();
                pts.push([stratum_point(i, u, k), stratum_point(j, v, k)]);
            }
        }
        pts
    } else {
        // Latin hypercube: one random permutation of the rows (Fisher-Yates, Knuth TAOCP 3.4.2).
        let mut perm: Vec<usize> = (0..count).collect();
        for i in (1..count).rev() {
            let j = rng.below(i as u64 + 1) as usize;
            perm.swap(i, j);
        }
        (0..count)
            .map(|i| {
                let u = rng.next_f64();
                let v = rng.next_f64();
                [stratum_point(i, u, count), stratum_point(perm[i], v, count)]
            })
            .collect()
    }
}

// ---------------------------------------------------------------------------------------------
// Sobol
// ---------------------------------------------------------------------------------------------

/// Generator matrix (as 32 column words, most significant bit = 2^-1) of Sobol's second
/// dimension: primitive polynomial x + 1 (degree 1), m_1 = 1, recurrence
/// `m_k = 2 m_{k-1} XOR m_{k-1}` (Bratley and Fox 1988), direction numbers `v_k = m_k / 2^k`.
/// In 32-bit fixed point `V_k = m_k << (32 - k)`, so `V_1 = 2^31` and
/// `V_k = V_{k-1} XOR (V_{k-1} >> 1)` (m = 1, 3, 5, 15, 17, 51, ...: Pascal's triangle mod 2).
const fn sobol_dim1_matrix() -> [u32; 32] {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
}

/// `sobol_dim1_matrix()` folded byte by byte: entry `[b][v]` is the XOR of `V_{8b+k+1}` over the set bits
/// k of v, so the matrix-vector product over GF(2) is four lookups (4 KiB) instead of a loop over
/// the index's bits.
const fn sobol_dim1_byte_tables() -> [[u32; 256]; 4] {
    let v = sobol_dim1_matrix();
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut byte = 0;
        while byte < 256 {
            let mut acc = 0u32;
            let mut k = 0;
            while k < 8 {
                if byte & (1 << k) != 0 {
                    acc ^= v[8 * b + k];
                }
                k += 1;
            }
            t[b][byte] = acc;
            byte += 1;
        }
        b += 1;
    }
    t
}

const SOBOL_DIM1_BYTES: [[u32; 256]; 4] = sobol_dim1_byte_tables();

/// The i-th point of the unscrambled 2D Sobol sequence as 32-bit fractions, in Gray-code order
/// (Antonov and Saleev 1979): with `g = i XOR (i >> 1)`,
/// `x = XOR_k g_k 2^(31-k)` (= bit reversal of g: van der Corput base 2) and
/// `y = XOR_k g_k V_{k+1}` (see `sobol_dim1_matrix`; computed a byte at a time). Gray-code order
/// permutes points only inside aligned blocks of 2^m, so every such block is the same
/// (0, m, 2)-net as in natural order.
#[inline]
pub fn sobol_2d_bits(i: u32) -> [u32; 2] {
    let g = i ^ (i >> 1);
    let x = g.reverse_bits();
    let t = &SOBOL_DIM1_BYTES;
    let y = t[0][(g & 0xFF) as usize]
        ^ t[1][((g >> 8) & 0xFF) as usize]
        ^ t[2][((g >> 16) & 0xFF) as usize]
        ^ t[3][(g >> 24) as usize];
    [x, y]
}

/// The i-th point of the unscrambled 2D Sobol sequence in [0, 1)^2 (seed-free; Gray-code order:
/// (0, 0), (0.5, 0.5), (0.75, 0.25), (0.25, 0.75), ...).
#[inline]
pub fn sobol_2d(i: u32) -> [f64; 2] {
    let [x, y] = sobol_2d_bits(i);
    [bits_to_unit(x), bits_to_unit(y)]
}

/// A 32-bit fraction to [0, 1): `b * 2^-32` (exact).
#[inline(always)]
pub(crate) fn bits_to_unit(b: u32) -> f64 {
    b as f64 * (1.0 / 4_294_967_296.0)
}

/// Per-dimension 32-bit scramble seeds derived from the user seed (two independent mixes).
fn sobol_seeds(seed: u64) -> (u32, u32) {
    let a = mix64(seed ^ 0x534F_424F_4C00_0000);
    let b = mix64(seed ^ 0x534F_424F_4C00_0001);
    ((a >> 32) as u32, (b >> 32) as u32)
}

/// Laine and Karras' hash (EGSR 2011), as given by Burley 2020, listing 2: each output bit
/// depends only on the input bits below it, so applied to bit-reversed values it is a nested
/// (Owen) permutation:
/// `x += seed; x ^= x*0x6c50b47c; x ^= x*0xb82f1e52; x ^= x*0xc7afe638; x ^= x*0x8d22f6e6`.
#[inline]
fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Burley 2020, listing 3: `reverse_bits(laine_karras(reverse_bits(x), seed))` — a hash-based
/// nested uniform (Owen) scramble of a 32-bit fraction.
#[inline]
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

// ---------------------------------------------------------------------------------------------
// Halton
// ---------------------------------------------------------------------------------------------

/// Digits used per base: enough that base^-digits < 2^-53 (2^-53 and 3^-34 ~ 6e-17).
const HALTON_DIGITS_BASE2: usize = 53;
const HALTON_DIGITS_BASE3: usize = 34;

/// One random permutation of {0, .., base-1} per digit position (Fisher-Yates).
fn digit_permutations(base: u64, digits: usize, seed: u64) -> Vec<Vec<u8>> {
    let mut rng = SplitMix64::new(seed);
    (0..digits)
        .map(|_| {
            let mut p: Vec<u8> = (0..base as u8).collect();
            for i in (1..p.len()).rev() {
                let j = rng.below(i as u64 + 1) as usize;
                p.swap(i, j);
            }
            p
        })
        .collect()
}

/// Scrambled radical inverse: `sum_{k>=1} perm_k(d_k(i)) b^-k`, over all `perms.len()` digit
/// positions (the index's leading zeros are permuted too, as in pbrt-v3 — otherwise the points
/// would not be a permutation of the strata), clamped below 1.
fn scrambled_radical_inverse(mut index: u64, base: u64, perms: &[Vec<u8>]) -> f64 {
    let inv_base = 1.0 / base as f64;
    let mut scale = inv_base;
    let mut v = 0.0f64;
    for perm in perms {
        let digit = (index % base) as usize;
        index /= base;
        v += perm[digit] as f64 * scale;
        scale *= inv_base;
    }
    v.min(ONE_MINUS_EPSILON)
}

/// Unscrambled radical inverse `phi_b(i) = sum_k d_k(i) b^-k` (van der Corput for b = 2).
pub fn radical_inverse(mut index: u64, base: u64) -> f64 {
    let inv_base = 1.0 / base as f64;
    let mut scale = inv_base;
    let mut v = 0.0f64;
    while index > 0 {
        v += (index % base) as f64 * scale;
        index /= base;
        scale *= inv_base;
    }
    v.min(ONE_MINUS_EPSILON)
}

#[cfg(test)]
mod tests;
