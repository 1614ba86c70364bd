//! Deterministic maths: phase reduction, sine/cosine, and the seeded random generator.
//!
//! Nothing here calls the platform's maths library for a value that reaches a model result:
//! `sin`/`cos` are a fixed polynomial kernel defined in this crate, and `exp`/`ln`/`pow` come from
//! the pure-Rust `libm` crate. Rust never contracts `a * b + c` into a fused multiply-add, so
//! every operation rounds the same way on x86-64 and aarch64, at every optimisation level.

mod phase;
mod rng;
mod trig;

pub use phase::{TAU, reduce_phase, reduce_turns, round_ties_away};
pub use rng::{SwellRng, mode_key, splitmix64};
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

/// Four-quadrant arctangent of `y / x`, from `libm`.
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
