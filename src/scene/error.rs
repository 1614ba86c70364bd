//! [`SceneError`]: why a scene spec or id was refused, in the scene's own terms.
//!
//! The domain says what went wrong and where (the field path); the API decides what a client
//! sees (code, status): `crate::error` maps each variant to an `ApiError`.

use swell_waves::SpecError;

/// A scene spec, or a scene id, that cannot be made into a scene. Nothing changed.
///
/// The `Display` text is the whole message for people (the API sends it as is).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// The spec is not JSON of a scene's shape: not an object, a wrongly typed field, an unknown
    /// field. `field` is the offending path (`layers[1].waves[0].amplitude`) when there is one.
    #[error("{message}")]
    Malformed {
        /// What was wrong, in words (for a path error it starts with the path).
        message: String,
        /// Path of the offending field.
        field: Option<String>,
    },
    /// The model (or the scene's own checks, in the model's terms) rejected a well-formed spec:
    /// a value out of range, a list of a bad length. The error names its field.
    #[error(transparent)]
    Rejected(#[from] SpecError),
    /// A scene id that is not `[a-z0-9-]{1,64}`.
    #[error("scene id {id:?} must match [a-z0-9-]{{1,64}}")]
    BadId {
        /// The id as given.
        id: String,
    },
}

impl SceneError {
    /// The path of the offending field, if the error names one (`id` for a bad id).
    #[must_use]
    pub fn field(&self) -> Option<&str> {
        let f = match self {
            SceneError::Malformed { field, .. } => field.as_deref()?,
            SceneError::Rejected(e) => e.field(),
            SceneError::BadId { .. } => "id",
        };
        (!f.is_empty()).then_some(f)
    }
}
