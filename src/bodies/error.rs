//! [`BodyError`]: why a body command was refused, in the body world's own terms.
//!
//! The domain says what went wrong and where (the field path); the API decides what a client
//! sees (code, status): `crate::error` maps each variant to an `ApiError`.

use swell_waves::SpecError;

/// A body command (spawn, input, remove, a state read) that was refused. Nothing changed.
///
/// The `Display` text is the whole message for people (the API sends it as is).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BodyError {
    /// No body with this id in the scene's world.
    #[error("no body with id {id} in this scene")]
    NotFound {
        /// The id asked for.
        id: u64,
    },
    /// A spawn into a world that already holds the scene's body limit.
    #[error("scene {scene} already has {max} bodies, the limit")]
    SceneFull {
        /// The scene.
        scene: String,
        /// Its body limit (`max_scene_bodies`).
        max: usize,
    },
    /// An input for a body that already holds [`crate::bodies::MAX_LIVE_INPUTS`] inputs that
    /// have not ended.
    #[error("body {id} already has {max} inputs acting or queued, the limit: wait for some to end")]
    TooManyInputs {
        /// The body.
        id: u64,
        /// The limit.
        max: usize,
    },
    /// A request value the body world cannot take: a non-finite position, a yaw out of range,
    /// an input tick in the past, a component the model refuses. `field` is the request's path
    /// (`position[1]`, `from_tick`, `force[0]`).
    #[error("{message}")]
    Invalid {
        /// Path of the offending field in the request.
        field: String,
        /// What was wrong, in words.
        message: String,
    },
    /// The model rejected a body spec or the world's settings (a scene tick rate or gravity out
    /// of the body model's range). The error names its field.
    #[error(transparent)]
    Rejected(#[from] SpecError),
}

impl BodyError {
    /// An [`BodyError::Invalid`] at `field`.
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        BodyError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
}
