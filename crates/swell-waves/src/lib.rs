//! Swell's wave model (placeholder root; documented fully below as modules land).
#![warn(missing_docs)]

pub mod error;
pub mod fft;
pub mod gerstner;
pub mod math;
pub mod sine;
pub mod spectrum;
pub mod wave;

pub use error::SpecError;
