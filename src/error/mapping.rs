//! The one mapping from each lower layer's error to [`ApiError`]: the domain says what went
//! wrong ([`SceneError`], [`BodyError`]), the registry and its store what they refused
//! ([`StateError`]), the query service which field or limit ([`QueryError`],
//! [`ClockUpdateError`], [`TimeOutOfRange`]), the byte budget which limit ([`OverBudget`],
//! [`ReserveRefused`]), the JSON and protobuf decoders where ([`JsonError`], [`ConvertError`]),
//! the answer guard which number was not finite ([`NonFinite`]); here, and only here, each
//! becomes the code, status, message and field a client sees. Callers above the domain keep
//! using `?`.

use super::{ApiError, ErrorCode};
use crate::bodies::BodyError;
use crate::config::TimeOutOfRange;
use crate::peers::{OverBudget, ReserveRefused};
use crate::scene::SceneError;
use crate::service::error::{ClockUpdateError, QueryError};
use crate::service::finite::NonFinite;
use crate::service::json::JsonError;
use crate::state::StateError;
use crate::wire::convert::ConvertError;

/// 400 `bad_json` with the decoder's message and field path.
impl From<JsonError> for ApiError {
    fn from(e: JsonError) -> Self {
        ApiError::bad_json(e.message).with_field(e.field.unwrap_or_default())
    }
}

/// A malformed spec is 400 `bad_json`, a bad id 400 `invalid_value` naming `id`, and a spec the
/// model rejects 422 `invalid_spec` with the model's message and field.
impl From<SceneError> for ApiError {
    fn from(e: SceneError) -> Self {
        match e {
            SceneError::Malformed { message, field } => {
                ApiError::bad_json(message).with_field(field.unwrap_or_default())
            }
            SceneError::Rejected(e) => ApiError::invalid_spec(&e),
            SceneError::BadId { .. } => ApiError::invalid("id", e.to_string()),
        }
    }
}

/// An unknown body is 404 `body_not_found` naming `body`; a spawn past the limit 409
/// `scene_full`, an input past a body's 409 `too_many_inputs`; a bad request value 400 `invalid_value` at its field; a spec or settings the
/// model rejects 422 `invalid_spec`.
impl From<BodyError> for ApiError {
    fn from(e: BodyError) -> Self {
        match e {
            BodyError::NotFound { .. } => {
                ApiError::new(ErrorCode::BodyNotFound, e.to_string()).with_field("body")
            }
            BodyError::SceneFull { .. } => ApiError::new(ErrorCode::SceneFull, e.to_string()),
            BodyError::TooManyInputs { .. } => {
                ApiError::new(ErrorCode::TooManyInputs, e.to_string())
            }
            BodyError::Invalid { field, message } => ApiError::invalid(field, message),
            BodyError::Rejected(e) => ApiError::invalid_spec(&e),
        }
    }
}

/// 500 `non_finite_result` naming where in the answer the number was (logged as an error: a
/// model fault, not the client's).
impl From<NonFinite> for ApiError {
    fn from(nf: NonFinite) -> Self {
        ApiError::non_finite(&nf)
    }
}

/// 400 `invalid_value` naming the time's field.
impl From<TimeOutOfRange> for ApiError {
    fn from(e: TimeOutOfRange) -> Self {
        ApiError::invalid(e.field.clone(), e.to_string())
    }
}

/// 400 `invalid_value` naming `t` or `rate`.
impl From<ClockUpdateError> for ApiError {
    fn from(e: ClockUpdateError) -> Self {
        ApiError::invalid(e.field().to_owned(), e.to_string())
    }
}

/// Too many points or probes is 413 `too_many_points`, too many bodies 413 `too_many_bodies`
/// (naming `bodies`); a name in `fields` that is not a field 400 `unknown_field`; a bad
/// coordinate, yaw, time or query setting 400 `invalid_value` at its field; a query past its
/// deadline 503 `timeout`; a failed query task 500 `internal` (logged, not sent).
impl From<QueryError> for ApiError {
    fn from(e: QueryError) -> Self {
        let field = e.field().unwrap_or_default();
        match e {
            QueryError::TooManyPoints { .. } => {
                ApiError::new(ErrorCode::TooManyPoints, e.to_string())
            }
            QueryError::TooManyBodies { .. } => {
                ApiError::new(ErrorCode::TooManyBodies, e.to_string())
            }
            QueryError::UnknownField { .. } => {
                ApiError::new(ErrorCode::UnknownField, e.to_string())
            }
            QueryError::Coordinate { .. }
            | QueryError::Yaw { .. }
            | QueryError::Time(_)
            | QueryError::Rejected(_) => ApiError::new(ErrorCode::InvalidValue, e.to_string()),
            QueryError::Timeout { .. } => ApiError::new(ErrorCode::Timeout, e.to_string()),
            QueryError::Task(detail) => return ApiError::internal(detail),
        }
        .with_field(field)
    }
}

/// 503 `overloaded`: a charge over the byte budget, counted in
/// `swell_http_buffer_budget_refused_total` (here, where the refusal becomes an answer).
impl From<OverBudget> for ApiError {
    fn from(e: OverBudget) -> Self {
        metrics::counter!("swell_http_buffer_budget_refused_total").increment(1);
        ApiError::overloaded(e.to_string())
    }
}

/// 503 `overloaded` naming the bytes asked for and the limit (counted where it was refused).
impl From<ReserveRefused> for ApiError {
    fn from(e: ReserveRefused) -> Self {
        ApiError::overloaded(e.to_string())
    }
}

/// 400 `invalid_value` naming the protobuf field that could not be converted.
impl From<ConvertError> for ApiError {
    fn from(e: ConvertError) -> Self {
        ApiError::invalid(e.field().to_owned(), e.to_string())
    }
}

/// An unknown scene is 404 `not_found` (also when a concurrent change through another replica
/// removed it); a new scene past `max_scenes` 409 `too_many_scenes`; FFT frames past
/// `max_fft_bytes` 422 `fft_budget` naming `layers`; an impact past a limit 409
/// `too_many_impacts`, one the model rejects 400 `invalid_value` at its field; an unreachable
/// shared store 503 `store_unavailable`; a fault on our side 500 `internal` (its detail was
/// logged where it happened and is not sent). Scene, body and clock errors map as their own.
impl From<StateError> for ApiError {
    fn from(e: StateError) -> Self {
        match e {
            StateError::SceneNotFound { id } => ApiError::scene_not_found(&id),
            StateError::SceneGone { .. } => ApiError::new(ErrorCode::NotFound, e.to_string()),
            StateError::TooManyScenes { .. } => {
                ApiError::new(ErrorCode::TooManyScenes, e.to_string())
            }
            StateError::FftBudget { .. } => {
                ApiError::new(ErrorCode::FftBudget, e.to_string()).with_field("layers")
            }
            StateError::Scene(e) => e.into(),
            StateError::Body(e) => e.into(),
            StateError::Clock(e) => e.into(),
            StateError::TooManyImpacts(why) => ApiError::new(ErrorCode::TooManyImpacts, why),
            StateError::ImpactRejected(e) => ApiError::invalid(e.field(), e.to_string()),
            StateError::StoreUnavailable(why) => ApiError::new(ErrorCode::StoreUnavailable, why),
            StateError::Internal(_) => ApiError::new(ErrorCode::Internal, "internal server error"),
        }
    }
}
