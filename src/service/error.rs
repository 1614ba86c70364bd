//! Why the service refused a query or a clock change, in the service's own terms: which field,
//! what value, what limit. What a client sees (code, status) is decided in `crate::error`,
//! which maps each variant once; HTTP handlers and the WebSocket session keep using `?`.

use swell_waves::SpecError;
use swell_waves::body::MAX_YAW;
use swell_waves::error::Num;

use crate::config::TimeOutOfRange;
use crate::service::types::FIELD_NAMES;

/// A query ([`crate::service::query`]) that was not answered. Nothing changed.
///
/// The `Display` text is the whole message for people (the API sends it as is).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum QueryError {
    /// More points (or probes) in one request than `max_points`.
    #[error("{field} asks for {n} points; at most {max} per request")]
    TooManyPoints {
        /// The request's field holding them (`points`, `bodies`).
        field: &'static str,
        /// Points (or probes) asked for.
        n: usize,
        /// [`crate::Limits::max_points`].
        max: usize,
    },
    /// More bodies in one orientation request than `max_bodies`.
    #[error("bodies has {n} entries; at most {max} per request")]
    TooManyBodies {
        /// Bodies asked for.
        n: usize,
        /// [`crate::Limits::max_bodies`].
        max: usize,
    },
    /// A name in `fields` that is not a field.
    #[error("fields[{index}] = {name:?} is not a field; expected one of {}", FIELD_NAMES.join(", "))]
    UnknownField {
        /// Its index in `fields`.
        index: usize,
        /// The name as given.
        name: String,
    },
    /// A coordinate that is not finite or is beyond `max_coordinate`.
    #[error("{field} = {} is out of range: a finite coordinate within ±{max} m", Num(*value))]
    Coordinate {
        /// Path of the coordinate (`points[3][0]`, `origin[1] + points[0][1]`).
        field: String,
        /// The coordinate, m.
        value: f64,
        /// [`crate::Limits::max_coordinate`], m.
        max: f64,
    },
    /// A body's yaw that is not finite or is beyond [`MAX_YAW`].
    #[error("{field} = {} is out of range: a finite angle with |yaw| <= {MAX_YAW} rad", Num(*value))]
    Yaw {
        /// Path of the yaw (`bodies[2].yaw`).
        field: String,
        /// The yaw, rad.
        value: f64,
    },
    /// The query's time is out of range.
    #[error(transparent)]
    Time(#[from] TimeOutOfRange),
    /// The model rejected a query setting (accuracy, a body's footprint, a time it cannot
    /// evaluate); the error names its field.
    #[error(transparent)]
    Rejected(#[from] SpecError),
    /// The work ran past `request_timeout_ms` and was abandoned.
    #[error("the sample took longer than {ms} ms (request_timeout_ms); ask for fewer points")]
    Timeout {
        /// [`crate::Limits::request_timeout_ms`].
        ms: u64,
    },
    /// The blocking task running the query failed (it panicked): a fault on our side.
    #[error("query task failed: {0}")]
    Task(String),
}

impl QueryError {
    /// The path of the offending field, if the error names one.
    #[must_use]
    pub fn field(&self) -> Option<String> {
        let f = match self {
            QueryError::TooManyPoints { field, .. } => (*field).to_owned(),
            QueryError::TooManyBodies { .. } => "bodies".to_owned(),
            QueryError::UnknownField { index, .. } => format!("fields[{index}]"),
            QueryError::Coordinate { field, .. } | QueryError::Yaw { field, .. } => field.clone(),
            QueryError::Time(e) => e.field.clone(),
            QueryError::Rejected(e) => e.field().to_owned(),
            QueryError::Timeout { .. } | QueryError::Task(_) => return None,
        };
        (!f.is_empty()).then_some(f)
    }
}

/// A clock change ([`crate::service::types::ClockUpdate::validate`]) with a number out of
/// range. Nothing changed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClockUpdateError {
    /// The seek time `t` is out of range.
    #[error(transparent)]
    Time(#[from] TimeOutOfRange),
    /// `rate` is not finite or beyond [`crate::scene::clock::MAX_RATE`].
    #[error("rate = {} is out of range: |rate| <= {max}", Num(*rate))]
    Rate {
        /// The rate as given.
        rate: f64,
        /// [`crate::scene::clock::MAX_RATE`].
        max: f64,
    },
}

impl ClockUpdateError {
    /// The offending field: `t` or `rate`.
    #[must_use]
    pub fn field(&self) -> &str {
        match self {
            ClockUpdateError::Time(e) => &e.field,
            ClockUpdateError::Rate { .. } => "rate",
        }
    }
}
