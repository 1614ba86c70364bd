//! Deterministic maths: phase reduction, sine/cosine, and the seeded random generator.
//!
//! Nothing here calls the platform's maths library for a value that reaches a model result:
//! `sin`/`cos` are a fixed polynomial kernel defined in this crate, and `exp`/`ln`/`pow` come from
//! the pure-Rust `libm` crate. Rust never contracts `a * b + c` into a fused multiply-add, so
//! every operation rounds the same way on x86-64 and aarch64, at every optimisation level.

mod phase;
mod rng;
mod trig;

#[cfg(target_arch = "x86_64")]
pub(crate) use phase::RoundByTrunc;
pub(crate) use phase::{RoundBySelects, Rounding};
pub use phase::{TAU, reduce_phase, reduce_turns, round_ties_away};
pub use rng::{SwellRng, mode_key, splitmix64};
pub(crate) use trig::sin_cos_phases;
pub use trig::{COSPI_F32, SINPI_F32, cos, sin, sin_cos, sin_cos_turns_f32};

/// `e^x`, from the pure-Rust `libm` crate (bit-identical on every platform).
#[inline]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// Natural logarithm, from `libm`.
#[inline]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// `x^y`, from `libm`.
#[inline]
pub fn pow(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// Hyperbolic tangent, from `libm`.
#[inline]
pub fn tanh(x: f64) -> f64 {
    libm::tanh(x)
}

/// RustFFT's inverse twiddle `e^{+2πi·index/len}`, bit for bit: the angle `(−2π/len)·index`
/// formed in f64 exactly as RustFFT's `compute_twiddle` forms it, then `(cos a, −sin a)` from the
/// platform's `cos` and `sin`, as RustFFT calls them.
///
/// The one use of platform trigonometry in frame maths, and not a new one: RustFFT's scalar
/// planner, which made every frame until the crate had its own FFT, computed its twiddles this
/// way, and the golden vectors pin frames made with them. Only plan time calls it (a few
/// thousand values per FFT size). The pure-Rust `libm` crate's cos/sin differ from glibc's in
/// the last bit for some of these angles (seen at N = 64), which would move every frame; a
/// test pins the crate's FFT to RustFFT's bit for bit, so a platform whose libm disagreed with
/// the one the vectors were minted on would fail the golden test rather than drift silently.
#[inline]
pub fn fft_inverse_twiddle(index: usize, len: usize) -> (f64, f64) {
    let constant = -2f64 * std::f64::consts::PI / len as f64;
    let angle = constant * index as f64;
    (angle.cos(), -angle.sin())
}

/// Four-quadrant arctangent of `y / x`, from `libm`.
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
