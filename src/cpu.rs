//! Processor features, below every other layer, and the one place the crate detects them: every
//! SIMD path asks here (the distribution's row kernels in `values::distribution::row_kernels`, the relight and
//! reference kernels in `maths::render::kernels`, the per-pixel batches, the hierarchical descent), so
//! they agree on what "AVX-512" and "AVX2" mean and are dispatched one way:
//!
//! - each `#[target_feature]` function is reached only through a safe dispatcher that asks
//!   [`features`] for what the function is compiled for, right before the call, so no caller can
//!   run it on a processor without them;
//! - interchangeable kernels (the same bits, different instruction sets) are the variants of one
//!   enum implementing [`Kernels`]: each says what it [needs](Kernels::needs), [`fastest`] picks
//!   the one that runs, and tests compare every one the processor has ([`available`]) with the
//!   portable one. Passing a variant the processor lacks is safe: its dispatcher falls back.
//!
//! The detection runs once ([`features`] caches it; the standard library's
//! `is_x86_feature_detected!` is called nowhere else).

use std::sync::OnceLock;

/// The instruction-set extensions the crate's SIMD paths are compiled for, beyond the baseline
/// (SSE2 on x86_64, which every x86_64 processor has; nothing elsewhere). All false off x86_64.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// AVX (256-bit float registers).
    pub avx: bool,
    /// FMA3 (fused multiply-adds; the exact reference's AVX kernel).
    pub fma: bool,
    /// AVX2 (256-bit integer operations and lane permutes; the distribution's second row kernel).
    pub avx2: bool,
    /// AVX-512F and DQ, the pair every AVX-512 path here is compiled for.
    pub avx512: bool,
}

impl Features {
    /// Nothing beyond the baseline: what a portable kernel needs.
    pub const BASELINE: Features = Features { avx: false, fma: false, avx2: false, avx512: false };

    /// Whether `self` has every feature of `need`.
    pub const fn covers(self, need: Features) -> bool {
        (self.avx || !need.avx) && (self.fma || !need.fma) && (self.avx2 || !need.avx2) && (self.avx512 || !need.avx512)
    }

    /// What this processor has.
    fn detect() -> Features {
        #[cfg(target_arch = "x86_64")]
        return Features {
            avx: is_x86_feature_detected!("avx"),
            fma: is_x86_feature_detected!("fma"),
            avx2: is_x86_feature_detected!("avx2"),
            avx512: is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512dq"),
        };
        #[cfg(not(target_arch = "x86_64"))]
        Features::BASELINE
    }
}

/// This processor's features, detected on the first call and cached (later calls are one
/// atomic load).
#[inline]
pub fn features() -> Features {
    static DETECTED: OnceLock<Features> = OnceLock::new();
    *DETECTED.get_or_init(Features::detect)
}

/// Whether this processor has AVX.
#[inline]
pub fn has_avx() -> bool {
    features().avx
}

/// Whether this processor has AVX and FMA.
#[inline]
pub fn has_avx_fma() -> bool {
    let f = features();
    f.avx && f.fma
}

/// Whether this processor has AVX2.
#[inline]
pub fn has_avx2() -> bool {
    features().avx2
}

/// Whether this processor has AVX-512F and DQ.
#[inline]
pub fn has_avx512() -> bool {
    features().avx512
}

/// A family of kernels that give the same bits with different instruction sets.
pub trait Kernels: Copy + PartialEq + 'static {
    /// Every kernel of the family that exists on this architecture, fastest first, ending with
    /// one that needs nothing beyond the baseline.
    const FASTEST_FIRST: &'static [Self];
    /// The features the kernel is compiled for.
    fn needs(self) -> Features;
}

/// Whether this processor runs kernel `k`.
#[inline]
pub fn runs<K: Kernels>(k: K) -> bool {
    features().covers(k.needs())
}

/// The fastest kernel of the family this processor runs (the last of
/// [`Kernels::FASTEST_FIRST`] if none before it does).
pub fn fastest<K: Kernels>() -> K {
    let all = K::FASTEST_FIRST;
    all.iter().copied().find(|&k| runs(k)).unwrap_or(all[all.len() - 1])
}

/// Every kernel of the family this processor runs, the portable one (the last of
/// [`Kernels::FASTEST_FIRST`]) first: the reference tests compare the others with.
pub fn available<K: Kernels>() -> Vec<K> {
    let mut kernels: Vec<K> = K::FASTEST_FIRST.iter().copied().filter(|&k| runs(k)).collect();
    kernels.rotate_right(1);
    kernels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Family {
        Wide,
        Narrow,
        Portable,
    }

    impl Kernels for Family {
        const FASTEST_FIRST: &'static [Self] = &[Family::Wide, Family::Narrow, Family::Portable];
        fn needs(self) -> Features {
            match self {
                Family::Wide => Features { avx512: true, ..Features::BASELINE },
                Family::Narrow => Features { avx2: true, ..Features::BASELINE },
                Family::Portable => Features::BASELINE,
            }
        }
    }

    #[test]
    fn covers_asks_for_every_needed_feature() {
        let avx_fma = Features { avx: true, fma: true, ..Features::BASELINE };
        assert!(avx_fma.covers(Features::BASELINE));
        assert!(avx_fma.covers(Features { avx: true, ..Features::BASELINE }));
        assert!(avx_fma.covers(avx_fma));
        assert!(!avx_fma.covers(Features { avx2: true, ..Features::BASELINE }));
        assert!(!Features { avx: true, ..Features::BASELINE }.covers(avx_fma));
        assert!(!Features::BASELINE.covers(Features { avx512: true, ..Features::BASELINE }));
    }

    #[test]
    fn the_choice_follows_the_detected_features() {
        let f = features();
        assert_eq!(f, features(), "cached");
        assert_eq!((has_avx(), has_avx2(), has_avx512()), (f.avx, f.avx2, f.avx512));
        assert_eq!(has_avx_fma(), f.avx && f.fma);
        let want = if f.avx512 {
            Family::Wide
        } else if f.avx2 {
            Family::Narrow
        } else {
            Family::Portable
        };
        assert_eq!(fastest::<Family>(), want);
        let all = available::<Family>();
        assert_eq!(all[0], Family::Portable, "the reference comes first");
        assert_eq!(all.contains(&Family::Wide), f.avx512);
        assert_eq!(all.contains(&Family::Narrow), f.avx2);
        assert_eq!(all.len(), 1 + f.avx512 as usize + f.avx2 as usize);
        #[cfg(not(target_arch = "x86_64"))]
        assert_eq!(f, Features::BASELINE);
    }
}
