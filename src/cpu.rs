//! Processor features, below every other layer: every SIMD path in the crate (the distribution's
//! rows in `data`, the per-pixel batches, the hierarchical descent and the relight and reference
//! kernels in `maths`) asks here, so they agree on what "AVX-512" and "AVX2" mean.

/// Whether this processor has AVX-512F and DQ, the features every AVX-512 path here is compiled
/// for (the standard library caches the detection). False off x86_64.
#[inline]
pub fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    return is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512dq");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Whether this processor has AVX2 (the distribution's second row kernel; most x86_64 processors
/// since 2013 that lack AVX-512 have it). False off x86_64.
#[inline]
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}
