//! Run-time choice of the SIMD width that batch kernels use, and how to force one.
//!
//! Every SIMD kernel in this crate is "vertical": it runs W independent problems (points, FFT
//! rows or columns) side by side, one per lane, and each lane performs exactly the scalar
//! operation sequence — the same `+`, `−`, `*`, `/`, `sqrt` on the same operands in the same
//! order, each rounded once. So the width changes the speed and never a bit: the scalar level is
//! the reference, and a test (`tests/simd_levels.rs`) compares every level the machine has
//! against it. No level enables FMA, and Rust never contracts `a * b + c` on its own.
//!
//! The level in use is the best the CPU has ([`SimdLevel::detected`]), capped by
//! - the environment variable `SWELL_SIMD` (`scalar`, `sse2`, `avx2` or `avx512`), read once per
//!   process: CI runs the level-identity test once per value;
//! - [`force_simd_level`], for tests and benchmarks in one process;
//! - [`crate::surface::set_simd_dispatch`]`(false)`, which means scalar.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// A SIMD width for the batch kernels, from narrowest to widest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// One lane, no vector instructions chosen at run time: the reference path.
    Scalar,
    /// Two f64 lanes (SSE2, present on every x86-64 CPU).
    Sse2,
    /// Four f64 lanes (AVX2).
    Avx2,
    /// Eight f64 lanes (AVX-512 F).
    Avx512,
}

impl SimdLevel {
    /// Every level, narrowest first.
    pub const ALL: [SimdLevel; 4] = [Self::Scalar, Self::Sse2, Self::Avx2, Self::Avx512];

    /// The name `SWELL_SIMD` takes for this level.
    pub fn name(self) -> &'static str {
        match self {
            Self::Scalar => "scalar",
            Self::Sse2 => "sse2",
            Self::Avx2 => "avx2",
            Self::Avx512 => "avx512",
        }
    }

    /// The level named `name` (as [`SimdLevel::name`] spells it), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|l| l.name().eq_ignore_ascii_case(name.trim()))
    }

    /// The widest level this CPU supports (scalar off x86-64).
    pub fn detected() -> Self {
        static DETECTED: OnceLock<SimdLevel> = OnceLock::new();
        *DETECTED.get_or_init(|| {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx512f") {
                    return Self::Avx512;
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    return Self::Avx2;
                }
                Self::Sse2
            }
            #[cfg(not(target_arch = "x86_64"))]
            Self::Scalar
        })
    }

    /// Every level this CPU can run, narrowest first.
    pub fn available() -> Vec<Self> {
        let best = Self::detected();
        Self::ALL.into_iter().filter(|&l| l <= best).collect()
    }

    /// The level set by `SWELL_SIMD`, if it is set to a level's name.
    ///
    /// # Panics
    /// If `SWELL_SIMD` is set to anything else: a typo in CI must not silently test the default.
    pub fn from_env() -> Option<Self> {
        static ENV: OnceLock<Option<SimdLevel>> = OnceLock::new();
        *ENV.get_or_init(|| {
            let v = std::env::var("SWELL_SIMD").ok()?;
            if v.trim().is_empty() {
                return None;
            }
            Some(Self::from_name(&v).unwrap_or_else(|| {
                panic!("SWELL_SIMD={v:?}: expected one of scalar, sse2, avx2, avx512")
            }))
        })
    }
}

/// Forced level (`FORCE_NONE`: none), see [`force_simd_level`].
static FORCED: AtomicU8 = AtomicU8::new(FORCE_NONE);
const FORCE_NONE: u8 = u8::MAX;

/// Caps the level of every batch kernel in this process (`None`: no cap beyond `SWELL_SIMD`).
/// Results are the same at every level; this exists so that tests and benchmarks can compare
/// them. A level the CPU lacks is capped to the CPU's.
#[doc(hidden)]
pub fn force_simd_level(level: Option<SimdLevel>) {
    FORCED.store(level.map_or(FORCE_NONE, |l| l as u8), Ordering::Relaxed);
}

/// The level batch kernels use now: the CPU's best, capped by `SWELL_SIMD`,
/// [`force_simd_level`] and [`crate::surface::set_simd_dispatch`].
#[inline]
pub fn simd_level() -> SimdLevel {
    if !crate::surface::simd_enabled() {
        return SimdLevel::Scalar;
    }
    let mut level = SimdLevel::detected();
    if let Some(env) = SimdLevel::from_env() {
        level = level.min(env);
    }
    let forced = FORCED.load(Ordering::Relaxed);
    if forced != FORCE_NONE {
        level = level.min(SimdLevel::ALL[usize::from(forced)]);
    }
    level
}
