//! [`StateError`]: why the registry or its store (the local journal, a fleet's Redis) refused
//! or failed a change or a lookup, in their own terms. What a client sees (code, status) is
//! decided in `crate::error`, which maps each variant once.

use swell_waves::SpecError;

use crate::bodies::BodyError;
use crate::impacts::AddError;
use crate::scene::SceneError;
use crate::service::error::ClockUpdateError;

/// A lookup or change of [`crate::state::AppState`] (through its [`crate::state::store::Store`])
/// that was not done. Unless the variant says otherwise, nothing changed.
///
/// The `Display` text is the whole message for people (the API sends it as is), except for
/// [`StateError::Internal`], whose detail is logged and never sent.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateError {
    /// No scene with this id.
    #[error("no scene with id {id:?}")]
    SceneNotFound {
        /// The id asked for.
        id: String,
    },
    /// The scene was changed through the shared store, and another replica's change (applied in
    /// between, in feed order) removed it before this one could read it back.
    #[error("scene {id:?} was deleted by a concurrent change through another replica")]
    SceneGone {
        /// The scene's id.
        id: String,
    },
    /// A new scene while the server holds [`crate::Limits::max_scenes`].
    #[error("the server holds {held} scenes, its limit (max_scenes); delete one first")]
    TooManyScenes {
        /// Scenes held now.
        held: usize,
    },
    /// The scene's FFT frames and every other scene's would exceed
    /// [`crate::Limits::max_fft_bytes`]; the client should change `layers`.
    #[error(
        "this scene's FFT layers need up to {} MiB of frames and the other scenes {} MiB: more than max_fft_bytes ({} MiB); lower a layer's resolution or delete a scene",
        mine >> 20,
        others >> 20,
        max >> 20
    )]
    FftBudget {
        /// This scene's frames, bytes.
        mine: u64,
        /// The other scenes' frames, bytes.
        others: u64,
        /// [`crate::Limits::max_fft_bytes`].
        max: u64,
    },
    /// A bad scene id or spec.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A body command refused by the body world.
    #[error(transparent)]
    Body(#[from] BodyError),
    /// A clock change with a number out of range.
    #[error(transparent)]
    Clock(#[from] ClockUpdateError),
    /// An impact past a scene's limits (the message says which).
    #[error("{0}")]
    TooManyImpacts(String),
    /// An impact the model rejects; the error names its field.
    #[error(transparent)]
    ImpactRejected(SpecError),
    /// The shared store (Redis) could not take or confirm the change; the message is for the
    /// operator and says what still works.
    #[error("{0}")]
    StoreUnavailable(String),
    /// A fault on our side (a journal write failed, an invariant broke). Made by
    /// [`StateError::internal`], which logs the detail where it happened; the client reads only
    /// that the server failed.
    #[error("internal error: {0}")]
    Internal(String),
}

impl StateError {
    /// [`StateError::Internal`], with `detail` logged as an error now.
    pub fn internal(detail: impl std::fmt::Display) -> Self {
        tracing::error!(%detail, "internal error");
        StateError::Internal(detail.to_string())
    }
}

/// A full scene is [`StateError::TooManyImpacts`]; an impact the model rejects
/// [`StateError::ImpactRejected`].
impl From<AddError> for StateError {
    fn from(e: AddError) -> Self {
        match e {
            AddError::Full(why) => StateError::TooManyImpacts(why),
            AddError::Invalid(e) => StateError::ImpactRejected(e),
        }
    }
}
