//! Processor features, below every other layer: every SIMD path in the crate (the distribution's
//! rows in `data`, the per-pixel batches, the hierarchical descent and the relight and reference
//! kernels in `maths`) asks here, so they agree on what "AVX-512" means.

/// Whether this processor has AVX-512F and DQ, the features every AVX-512 path here is compiled
/// for (the standard library caches the detection). False off x86_64.
#[inline]
pub fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    return is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512dq");
    #[cfg(not(target_arch = "x86_64"))]
    false
}
