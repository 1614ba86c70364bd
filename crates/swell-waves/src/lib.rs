//! Swell's wave model (placeholder root; documented fully below as modules land).
#![warn(missing_docs)]

pub mod error;
pub mod fft;
pub mod math;
pub mod spectrum;

pub use error::SpecError;
