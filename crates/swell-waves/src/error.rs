//! Typed validation errors.
//!
//! Every spec is validated before anything is built from it. An error names the field (a path
//! such as `layers[1].waves[3].amplitude`), the offending value and what would have been allowed,
//! so a server can hand the message straight back to the client that sent the spec.

use thiserror::Error;

/// Why a spec, query or body was rejected.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpecError {
    /// A number is NaN or infinite.
    #[error("{field} must be a finite number, got {}", Num(*value))]
    NotFinite {
        /// Path of the field, e.g. `layers[0].waves[2].wavelength`.
        field: String,
        /// The value received.
        value: f64,
    },
    /// A number lies outside its allowed range.
    #[error("{field} = {} is out of range: {allowed}", Num(*value))]
    OutOfRange {
        /// Path of the field.
        field: String,
        /// The value received.
        value: f64,
        /// The allowed range, in words, e.g. `> 0 m` or `in [0, 1]`.
        allowed: String,
    },
    /// A direction vector `[x, z]` has zero length and cannot be normalised.
    #[error("{field} is a zero vector; a direction needs a non-zero [x, z]")]
    ZeroDirection {
        /// Path of the field.
        field: String,
    },
    /// The Gerstner fold number `S = Σ Q·k·A` is 1 or more: the surface would loop over itself.
    #[error(
        "{field}: fold number S = sum(Q*k*A) = {fold} must be < 1 or the surface loops over itself; \
         lower the steepness or the amplitudes"
    )]
    Folding {
        /// Path of the layer.
        field: String,
        /// The fold number computed.
        fold: f64,
    },
    /// A list is empty or longer than allowed.
    #[error("{field} has {len} entries; allowed: {allowed}")]
    BadLength {
        /// Path of the field.
        field: String,
        /// Length received.
        len: usize,
        /// Allowed lengths, in words.
        allowed: String,
    },
    /// A combination of otherwise valid fields is inconsistent.
    #[error("{field}: {reason}")]
    Inconsistent {
        /// Path of the field.
        field: String,
        /// What is wrong.
        reason: String,
    },
}

impl SpecError {
    /// The path of the offending field.
    pub fn field(&self) -> &str {
        match self {
            SpecError::NotFinite { field, .. }
            | SpecError::OutOfRange { field, .. }
            | SpecError::ZeroDirection { field }
            | SpecError::Folding { field, .. }
            | SpecError::BadLength { field, .. }
            | SpecError::Inconsistent { field, .. } => field,
        }
    }
}

/// The path of field `name` inside the value at `prefix`: `prefix.name`, or `name` alone when
/// `prefix` is empty (a value at the root of the document its sender wrote, such as a spawn
/// request's body spec: `mass`, `hull.length`).
pub(crate) fn field_path(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}.{name}")
    }
}

/// Checks a number is finite.
pub(crate) fn finite(field: &str, value: f64) -> Result<f64, SpecError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SpecError::NotFinite {
            field: field.to_string(),
            value,
        })
    }
}

/// Checks a number is finite and strictly positive.
pub(crate) fn positive(field: &str, value: f64) -> Result<f64, SpecError> {
    finite(field, value)?;
    if value > 0.0 {
        Ok(value)
    } else {
        Err(SpecError::OutOfRange {
            field: field.to_string(),
            value,
            allowed: "> 0".to_string(),
        })
    }
}

/// Checks a number is finite, strictly positive and at most `max`.
pub(crate) fn positive_at_most(field: &str, value: f64, max: f64) -> Result<f64, SpecError> {
    finite(field, value)?;
    if value > 0.0 && value <= max {
        Ok(value)
    } else {
        Err(SpecError::OutOfRange {
            field: field.to_string(),
            value,
            allowed: format!("in (0, {max}]"),
        })
    }
}

/// A number as an error message shows it: Rust's shortest round-trip form (`0.25`, `1000`)
/// between 10⁻⁴ and 10¹⁵ in magnitude (and 0), scientific notation (`1e300`, `5e-324`) outside,
/// so a client's `1e300` comes back as `1e300`, not as 301 digits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e15).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// Checks a number is finite and not negative.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<f64, SpecError> {
    finite(field, value)?;
    if value >= 0.0 {
        Ok(value)
    } else {
        Err(SpecError::OutOfRange {
            field: field.to_string(),
            value,
            allowed: ">= 0".to_string(),
        })
    }
}

/// Checks a number is finite and in `[lo, hi]`.
pub(crate) fn in_range(field: &str, value: f64, lo: f64, hi: f64) -> Result<f64, SpecError> {
    finite(field, value)?;
    if (lo..=hi).contains(&value) {
        Ok(value)
    } else {
        Err(SpecError::OutOfRange {
            field: field.to_string(),
            value,
            allowed: format!("in [{lo}, {hi}]"),
        })
    }
}

/// Checks a direction `[x, z]` is finite and non-zero, and returns it normalised.
pub(crate) fn direction(field: &str, d: [f64; 2]) -> Result<glam::DVec2, SpecError> {
    finite(&format!("{field}[0]"), d[0])?;
    finite(&format!("{field}[1]"), d[1])?;
    let v = glam::DVec2::new(d[0], d[1]);
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        Ok(v / len)
    } else if len > 0.0 {
        // Both components finite but the length overflowed: rescale first.
        let m = d[0].abs().max(d[1].abs());
        let w = v / m;
        Ok(w / w.length())
    } else {
        Err(SpecError::ZeroDirection {
            field: field.to_string(),
        })
    }
}
