//! Instruction sets, below every other layer: the one place the crate detects the processor's
//! features, the level every SIMD path runs at, and `dispatch!`, the macro that compiles a
//! kernel once per level.
//!
//! # Levels
//!
//! A [`Level`] names what a kernel may use beyond the target's baseline:
//!
//! - `portable`: nothing (SSE2 on x86_64, which every x86_64 processor has; the only level
//!   elsewhere). The hand-written kernels of `maths::render::kernels` use SSE2 at this level.
//! - `avx2`: AVX, AVX2 and FMA (Intel Haswell and AMD Zen on). What the kernels compiled for it
//!   need: AVX (the relighting sums), AVX and FMA (the exact reference's sums), AVX2 (the
//!   distribution's row scan), AVX2 and FMA (the IBL loops). A processor with AVX but without
//!   AVX2 or FMA (Sandy and Ivy Bridge) runs `portable`.
//! - `avx512`: `avx2` plus AVX-512F and DQ (Intel Skylake-X and Ice Lake, AMD Zen 4 on).
//!
//! [`detected`] is the widest level the processor has, found once; [`available_levels`] every
//! level it has, `portable` first.
//!
//! # `HDRFLOW_CPU`
//!
//! [`level`], the level every kernel runs at unless told otherwise, is the processor's widest,
//! or the one the environment variable `HDRFLOW_CPU` forces: `portable`, `avx2` or `avx512`
//! (ASCII case ignored), e.g. `HDRFLOW_CPU=portable hdrflow run ...` to rule out a SIMD path when
//! a result looks wrong, or to run the portable code on a processor that has more. Any other
//! value (the empty one included), or a level the processor lacks, is a [`CpuError`] that names
//! the variable. The variable is read once, on first use. `docs/src/internals/cpu.md` says the same for users.
//!
//! A kernel cannot report that error (it asks [`level`] deep inside a bake), so the programs
//! report it before any work: the command line (`cli::main_from_with_extra`, exit code 2) and the
//! Python module (its import raises `RuntimeError`) call [`init`] first. Library code that never
//! called [`init`] is not stopped by a bad value: [`level`] then falls back to [`detected`] (a
//! valid value is obeyed either way).
//!
//! # Dispatch
//!
//! Every SIMD path has an entry that takes the [`Level`] explicitly (tests run each level the
//! processor has in one process) and one that passes [`level`]. A level the processor lacks is
//! safe to pass: [`usable`] lowers it to [`detected`], and every `#[target_feature]` function is
//! reached only through a dispatcher that asked [`usable`] right before the call.
//!
//! - A loop the compiler vectorises is written once, as an `#[inline(always)]` function, and
//!   `dispatch!` compiles it for each level inside a `#[target_feature]` wrapper (the IBL
//!   loops of `maths::ibl`, the per-pixel batches of `maths::render::per_pixel::lanes`). A generic
//!   helper taking a closure (`widest(|| ...)`) was tried and made a bake 12% slower: the
//!   closure's body was not inlined into the wrapper, so it ran as baseline code.
//! - Hand-written intrinsics (`maths::render::kernels`, the distribution's row kernels, the
//!   hierarchical warp's descent) `match` on [`usable`].
//!
//! # Numerics
//!
//! Every kernel gives the same bits at every level, and its tests compare each level the
//! processor has with `portable`, bit for bit: Rust never contracts `a * b + c` into a fused
//! multiply-add on its own, so a body compiled with FMA enabled rounds as the portable one does;
//! the hand-written kernels do the portable code's IEEE operations in its order, and where they
//! fuse (the exact reference's sums) the portable code calls `mul_add`, IEEE's fused operation.
//! No level therefore needs a tolerance; a test that compares a kernel with a different formula
//! (an f64 reference, another summation order) states its bound where it does so. A level the
//! test machine lacks is compiled but not run, and its tests say so (`tested_levels`).

use std::ffi::OsStr;
use std::fmt;
use std::sync::OnceLock;

/// The environment variable that forces a [`Level`].
pub const ENV_VAR: &str = "HDRFLOW_CPU";

/// What a kernel may use beyond the baseline (see the module documentation); ordered, each level
/// including the ones below it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// The target's baseline (SSE2 on x86_64).
    Portable,
    /// AVX, AVX2 and FMA.
    Avx2,
    /// AVX2's features plus AVX-512F and DQ.
    Avx512,
}

impl Level {
    /// Every level, narrowest first.
    pub const ALL: [Level; 3] = [Level::Portable, Level::Avx2, Level::Avx512];

    /// The level's name, as `HDRFLOW_CPU` takes it.
    pub const fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    /// The level named `name` (ASCII case ignored).
    pub fn from_name(name: &str) -> Option<Level> {
        Level::ALL.into_iter().find(|l| l.name().eq_ignore_ascii_case(name))
    }
}

impl fmt::Display for Level {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A bad `HDRFLOW_CPU`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CpuError {
    /// Not the name of a level.
    #[error(
        "HDRFLOW_CPU={value:?} is not an instruction set: use portable, avx2 or avx512 (this processor has up to \
         {widest}), or unset HDRFLOW_CPU for the widest"
    )]
    Unknown { value: String, widest: Level },
    /// A level the processor lacks.
    #[error("HDRFLOW_CPU={asked}: this processor lacks that instruction set (it has up to {widest})")]
    Missing { asked: Level, widest: Level },
}

/// The widest level this processor has.
fn detect() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 =
            is_x86_feature_detected!("avx") && is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        let avx512 = avx2 && is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512dq");
        if avx512 {
            return Level::Avx512;
        }
        if avx2 {
            return Level::Avx2;
        }
    }
    Level::Portable
}

/// The widest level this processor has, detected on the first call and cached (later calls are
/// one atomic load). The standard library's `is_x86_feature_detected!` is called nowhere else.
#[inline]
pub fn detected() -> Level {
    static DETECTED: OnceLock<Level> = OnceLock::new();
    *DETECTED.get_or_init(detect)
}

/// Whether this processor has `level`.
#[inline]
pub fn supports(level: Level) -> bool {
    level <= detected()
}

/// `level`, or the widest level this processor has if it lacks `level`: what a dispatcher runs
/// when asked for `level`.
#[inline]
pub fn usable(level: Level) -> Level {
    level.min(detected())
}

/// Every level this processor has, `portable` first: the reference the tests compare the others
/// with.
pub fn available_levels() -> Vec<Level> {
    Level::ALL.into_iter().filter(|&l| supports(l)).collect()
}

/// The level `HDRFLOW_CPU`'s `value` asks for on a processor whose widest is `widest` (`None`:
/// the variable is not set).
fn choose(value: Option<&OsStr>, widest: Level) -> Result<Level, CpuError> {
    let Some(value) = value else {
        return Ok(widest);
    };
    let unknown = || CpuError::Unknown { value: value.to_string_lossy().into_owned(), widest };
    let asked = value.to_str().and_then(Level::from_name).ok_or_else(unknown)?;
    if asked > widest {
        return Err(CpuError::Missing { asked, widest });
    }
    Ok(asked)
}

/// `HDRFLOW_CPU` against this processor, read on the first call and cached.
fn chosen() -> &'static Result<Level, CpuError> {
    static CHOSEN: OnceLock<Result<Level, CpuError>> = OnceLock::new();
    CHOSEN.get_or_init(|| choose(std::env::var_os(ENV_VAR).as_deref(), detected()))
}

/// The level kernels run at ([`level`]), or the error of a bad `HDRFLOW_CPU`: for programs to
/// call before any work, and report.
pub fn init() -> Result<Level, CpuError> {
    chosen().clone()
}

/// The level kernels run at: the one `HDRFLOW_CPU` forces, else the widest this processor has
/// (also when `HDRFLOW_CPU` is bad: see [`init`]).
#[inline]
pub fn level() -> Level {
    match chosen() {
        Ok(level) => *level,
        Err(_) => detected(),
    }
}

/// Declares a dispatcher `name(level: Level, args...)` that runs `body(args...)` compiled for
/// the widest of the listed levels that [`usable`]`(level)` reaches, or for the baseline:
///
/// ```text
/// cpu::dispatch! {
///     #[levels(Avx512, Avx2)]
///     /// `sums_lanes`, compiled for AVX-512, for AVX2 and FMA, and for the baseline.
///     #[inline]
///     pub(crate) fn sums(samples: &Samples, n: DVec3) -> [f64; 3] = sums_lanes;
/// }
/// ```
///
/// Each listed level gets an `unsafe fn` with that level's `#[target_feature]`s (`Avx2`: `avx,
/// avx2, fma`; `Avx512`: those and `avx512f, avx512dq`), declared inside the dispatcher, that
/// calls `body`; `body` must be `#[inline(always)]`, so that its code is compiled inside each
/// wrapper for that level (otherwise each wrapper calls the one baseline copy). List levels
/// widest first. Arguments are plain names; `body` is a path to a function (not through `Self`,
/// which the nested wrappers cannot name: write `Type::method` and pass the receiver as the first
/// argument). The dispatcher's attributes are the given ones.
macro_rules! dispatch {
    (
        #[levels($($level:ident),+ $(,)?)]
        $(#[$attr:meta])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $body:path;
    ) => {
        $(#[$attr])*
        $vis fn $name(level: $crate::cpu::Level, $($arg: $ty),*) $(-> $ret)? {
            let usable = $crate::cpu::usable(level);
            $crate::cpu::dispatch!(@arms usable, $body, [$($level),+], ($($arg: $ty),*) $(-> $ret)?);
            let _ = usable;
            $body($($arg),*)
        }
    };
    (@arms $usable:ident, $body:path, [$first:ident $(, $rest:ident)*], $args:tt $(-> $ret:ty)?) => {
        $crate::cpu::dispatch!(@compiled $first, $usable, $body, $args $(-> $ret)?);
        $crate::cpu::dispatch!(@arms $usable, $body, [$($rest),*], $args $(-> $ret)?);
    };
    (@arms $usable:ident, $body:path, [], $args:tt $(-> $ret:ty)?) => {};
    (@compiled Avx512, $usable:ident, $body:path, ($($arg:ident: $ty:ty),*) $(-> $ret:ty)?) => {
        #[cfg(target_arch = "x86_64")]
        if $usable >= $crate::cpu::Level::Avx512 {
            #[target_feature(enable = "avx,avx2,fma,avx512f,avx512dq")]
            unsafe fn avx512($($arg: $ty),*) $(-> $ret)? {
                $body($($arg),*)
            }
            // SAFETY: `cpu::usable` gave a level the processor has, which includes these features.
            return unsafe { avx512($($arg),*) };
        }
    };
    (@compiled Avx2, $usable:ident, $body:path, ($($arg:ident: $ty:ty),*) $(-> $ret:ty)?) => {
        #[cfg(target_arch = "x86_64")]
        if $usable >= $crate::cpu::Level::Avx2 {
            #[target_feature(enable = "avx,avx2,fma")]
            unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                $body($($arg),*)
            }
            // SAFETY: `cpu::usable` gave a level the processor has, which includes these features.
            return unsafe { avx2($($arg),*) };
        }
    };
}
pub(crate) use dispatch;

/// The levels a test runs a kernel at: [`available_levels`], after a visible skip banner
/// (`crate::test_skip`) for each level this processor lacks, whose code was compiled but will
/// not run (a failure instead when `HDRFLOW_REQUIRE_AVX2` or `HDRFLOW_REQUIRE_AVX512` is `1`).
#[cfg(test)]
pub(crate) fn tested_levels() -> Vec<Level> {
    for missing in Level::ALL.into_iter().filter(|&l| !supports(l)) {
        crate::test_skip::skip(
            &format!("HDRFLOW_REQUIRE_{}", missing.name().to_ascii_uppercase()),
            &format!("this processor lacks {missing}: its kernels are compiled but not run"),
        );
    }
    available_levels()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_are_ordered_and_named() {
        assert!(Level::Portable < Level::Avx2 && Level::Avx2 < Level::Avx512);
        for l in Level::ALL {
            assert_eq!(Level::from_name(l.name()), Some(l));
            assert_eq!(Level::from_name(&l.name().to_ascii_uppercase()), Some(l));
            assert_eq!(l.to_string(), l.name());
        }
        assert_eq!(Level::from_name("avx"), None);
        assert_eq!(Level::from_name(""), None);
    }

    #[test]
    fn the_variable_forces_a_level_the_processor_has() {
        let os = |s: &str| Some(OsStr::new(s).to_owned());
        assert_eq!(choose(None, Level::Avx2), Ok(Level::Avx2));
        assert_eq!(choose(os("portable").as_deref(), Level::Avx2), Ok(Level::Portable));
        assert_eq!(choose(os("AVX2").as_deref(), Level::Avx2), Ok(Level::Avx2));
        assert_eq!(choose(os("avx512").as_deref(), Level::Avx512), Ok(Level::Avx512));
        assert_eq!(
            choose(os("avx512").as_deref(), Level::Avx2),
            Err(CpuError::Missing { asked: Level::Avx512, widest: Level::Avx2 })
        );
        for bad in ["bogus", "", " avx2", "sse2"] {
            let err = choose(os(bad).as_deref(), Level::Portable).unwrap_err();
            assert_eq!(err, CpuError::Unknown { value: bad.into(), widest: Level::Portable });
            assert!(err.to_string().starts_with("HDRFLOW_CPU="), "{err}");
        }
        let missing = choose(os("avx2").as_deref(), Level::Portable).unwrap_err().to_string();
        assert_eq!(missing, "HDRFLOW_CPU=avx2: this processor lacks that instruction set (it has up to portable)");
        #[cfg(unix)]
        {
            use std::os::unix::ffi::OsStrExt;
            let err = choose(Some(OsStr::from_bytes(b"avx\xff")), Level::Avx2).unwrap_err();
            assert!(matches!(err, CpuError::Unknown { .. }) && err.to_string().contains("HDRFLOW_CPU"));
        }
    }

    #[test]
    fn the_levels_follow_the_processor() {
        let widest = detected();
        assert_eq!(widest, detected(), "cached");
        let all = available_levels();
        assert_eq!(all[0], Level::Portable, "the reference comes first");
        assert_eq!(*all.last().unwrap(), widest);
        assert_eq!(all.len(), Level::ALL.iter().filter(|&&l| l <= widest).count());
        for l in Level::ALL {
            assert_eq!(supports(l), l <= widest);
            assert_eq!(usable(l), if supports(l) { l } else { widest });
        }
        // The variable as this process has it: the level is the forced one or the widest.
        match init() {
            Ok(l) => assert_eq!(level(), l),
            Err(_) => assert_eq!(level(), widest),
        }
        assert!(supports(level()));
        #[cfg(not(target_arch = "x86_64"))]
        assert_eq!(widest, Level::Portable);
    }

    /// Sums of products: a loop the compiler vectorises (for AVX2, with FMA enabled).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lane i of both arrays
    fn dot_lanes(a: &[f64], b: &[f64]) -> f64 {
        let mut acc = [0.0f64; 8];
        for (a, b) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
            for i in 0..8 {
                acc[i] += a[i] * b[i];
            }
        }
        acc.iter().sum()
    }

    dispatch! {
        #[levels(Avx512, Avx2)]
        /// [`dot_lanes`] at a level.
        fn dot(a: &[f64], b: &[f64]) -> f64 = dot_lanes;
    }

    dispatch! {
        #[levels(Avx512)]
        /// [`dot_lanes`] into `out`, compiled for AVX-512 only.
        fn dot_into(a: &[f64], b: &[f64], out: &mut f64) = dot_into_lanes;
    }

    #[inline(always)]
    fn dot_into_lanes(a: &[f64], b: &[f64], out: &mut f64) {
        *out = dot_lanes(a, b);
    }

    /// Every level, those the processor lacks included (they run the widest it has), gives the
    /// portable bits: the multiplies and adds are not fused into FMAs.
    #[test]
    fn a_dispatched_body_gives_the_same_bits_at_every_level() {
        let a: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.37).sin() * 1e3).collect();
        let b: Vec<f64> = (0..1000).map(|i| 1.0 / (1.0 + i as f64 * 0.11)).collect();
        let portable = dot(Level::Portable, &a, &b);
        for l in Level::ALL {
            assert_eq!(dot(l, &a, &b).to_bits(), portable.to_bits(), "{l}");
            let mut out = f64::NAN;
            dot_into(l, &a, &b, &mut out);
            assert_eq!(out.to_bits(), portable.to_bits(), "{l}");
        }
    }
}
