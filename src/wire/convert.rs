//! Protobuf ↔ API structs, in one place.
//!
//! Requests decode from protobuf into the very structs JSON decodes into
//! ([`crate::service::types`]), so both transports run the same query code and give the same bits.
//! Responses are built once (as the API structs) and converted for the protobuf wire; f64 values
//! are moved, never recomputed or rounded.
//!
//! Enum values: `*_UNSPECIFIED` means "server default" for `InversionMethod` and `Filter`, and is
//! rejected for `Field` (a field list must name real fields); a number outside the enum (a newer
//! client, or garbage) is a [`ConvertError`] naming the field, which `crate::error` maps to 400
//! `invalid_value`.

use swell_waves::InversionMethod;

use crate::service::types::{
    Accuracy, Body, BodyOrientation, BodyState, Filter, HeightResponse, OrientationRequest,
    OrientationResponse, Precision, SampleRequest, SampleResponse, Tick,
};
use crate::wire::v1;

fn xz(p: &v1::Point2) -> [f64; 2] {
    [p.x, p.z]
}

fn v3(v: [f64; 3]) -> v1::Vec3 {
    v1::Vec3 {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

fn quat(q: [f64; 4]) -> v1::Quat {
    v1::Quat {
        x: q[0],
        y: q[1],
        z: q[2],
        w: q[3],
    }
}

/// A protobuf request that decodes but cannot be made into the API's request: an enum value
/// it may not hold, a required field left out. The `Display` text is the whole message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConvertError {
    /// An enum field holding `FIELD_UNSPECIFIED` where a value is needed, or a number outside
    /// the enum (a newer client, or garbage).
    #[error("{field} = {value} {why}")]
    BadEnum {
        /// Path of the field (`fields[2]`, `accuracy.method`).
        field: String,
        /// The number as sent.
        value: i32,
        /// Why it was refused, in words.
        why: &'static str,
    },
    /// A message field that must be present is absent.
    #[error("{field} is required")]
    Missing {
        /// Path of the field (`bodies[0].position`).
        field: String,
    },
}

impl ConvertError {
    /// The path of the offending field.
    #[must_use]
    pub fn field(&self) -> &str {
        match self {
            ConvertError::BadEnum { field, .. } | ConvertError::Missing { field } => field,
        }
    }
}

fn bad_enum(field: &str, value: i32, why: &'static str) -> ConvertError {
    ConvertError::BadEnum {
        field: field.to_owned(),
        value,
        why,
    }
}

/// The wire name of a protobuf field value (as JSON spells it).
///
/// # Errors
/// [`ConvertError::BadEnum`] naming `field` for `FIELD_UNSPECIFIED` or a value outside the enum.
fn field_name(field: &str, value: i32) -> Result<String, ConvertError> {
    match v1::Field::try_from(value) {
        Ok(v1::Field::Height) => Ok("height".into()),
        Ok(v1::Field::Normal) => Ok("normal".into()),
        Ok(v1::Field::Displacement) => Ok("displacement".into()),
        Ok(v1::Field::Jacobian) => Ok("jacobian".into()),
        Ok(v1::Field::Residual) => Ok("residual".into()),
        Ok(v1::Field::Unspecified) => Err(bad_enum(
            field,
            value,
            "is FIELD_UNSPECIFIED; name a field (FIELD_HEIGHT, FIELD_NORMAL, ...)",
        )),
        Err(_) => Err(bad_enum(field, value, "is not a Field value")),
    }
}

impl TryFrom<v1::Accuracy> for Accuracy {
    type Error = ConvertError;

    fn try_from(a: v1::Accuracy) -> Result<Self, ConvertError> {
        let method = match v1::InversionMethod::try_from(a.method) {
            Ok(v1::InversionMethod::Unspecified) => None,
            Ok(v1::InversionMethod::Newton) => Some(InversionMethod::Newton),
            Ok(v1::InversionMethod::FixedPoint) => Some(InversionMethod::FixedPoint),
            Err(_) => {
                return Err(bad_enum(
                    "accuracy.method",
                    a.method,
                    "is not an InversionMethod value",
                ));
            }
        };
        let filter = match v1::Filter::try_from(a.filter) {
            Ok(v1::Filter::Unspecified) => None,
            Ok(v1::Filter::Nearest) => Some(Filter::Nearest),
            Ok(v1::Filter::Bilinear) => Some(Filter::Bilinear),
            Ok(v1::Filter::Bicubic) => Some(Filter::Bicubic),
            Err(_) => {
                return Err(bad_enum(
                    "accuracy.filter",
                    a.filter,
                    "is not a Filter value",
                ));
            }
        };
        let precision = match v1::Precision::try_from(a.precision) {
            Ok(v1::Precision::Unspecified) => None,
            Ok(v1::Precision::F64) => Some(Precision::F64),
            Ok(v1::Precision::F32) => Some(Precision::F32),
            Err(_) => {
                return Err(bad_enum(
                    "accuracy.precision",
                    a.precision,
                    "is not a Precision value",
                ));
            }
        };
        let time = match v1::TimeSampling::try_from(a.time) {
            Ok(v1::TimeSampling::Unspecified) => None,
            Ok(v1::TimeSampling::Grid) => Some(swell_waves::TimeSampling::Grid),
            Ok(v1::TimeSampling::Exact) => Some(swell_waves::TimeSampling::Exact),
            Err(_) => {
                return Err(bad_enum(
                    "accuracy.time",
                    a.time,
                    "is not a TimeSampling value",
                ));
            }
        };
        Ok(Accuracy {
            method,
            iterations: a.iterations,
            tolerance: a.tolerance,
            filter,
            precision,
            time,
        })
    }
}

impl TryFrom<v1::SampleRequest> for SampleRequest {
    type Error = ConvertError;

    /// An empty `fields` list means the default (height), as an absent JSON `fields` does.
    fn try_from(r: v1::SampleRequest) -> Result<Self, ConvertError> {
        let fields = if r.fields.is_empty() {
            None
        } else {
            Some(
                r.fields
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| field_name(&format!("fields[{i}]"), f))
                    .collect::<Result<Vec<_>, _>>()?,
            )
        };
        Ok(SampleRequest {
            t: r.t,
            origin: r.origin.as_ref().map(xz),
            points: r.points.iter().map(xz).collect(),
            fields,
            accuracy: r.accuracy.map(Accuracy::try_from).transpose()?,
        })
    }
}

impl TryFrom<v1::OrientationRequest> for OrientationRequest {
    type Error = ConvertError;

    /// An empty `probes` list means the default 3×3 grid, as an absent JSON `probes` does.
    fn try_from(r: v1::OrientationRequest) -> Result<Self, ConvertError> {
        let bodies = r
            .bodies
            .into_iter()
            .enumerate()
            .map(|(i, b)| {
                let Some(position) = b.position.as_ref().map(xz) else {
                    return Err(ConvertError::Missing {
                        field: format!("bodies[{i}].position"),
                    });
                };
                Ok(Body {
                    position,
                    yaw: b.yaw,
                    length: b.length,
                    beam: b.beam,
                    probes: if b.probes.is_empty() {
                        None
                    } else {
                        Some(b.probes.iter().map(xz).collect())
                    },
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(OrientationRequest { t: r.t, bodies })
    }
}

impl From<SampleResponse> for v1::SampleResponse {
    fn from(r: SampleResponse) -> Self {
        v1::SampleResponse {
            t: r.t,
            height: r.height.unwrap_or_default(),
            normal: r.normal.unwrap_or_default().into_iter().map(v3).collect(),
            displacement: r
                .displacement
                .unwrap_or_default()
                .into_iter()
                .map(v3)
                .collect(),
            jacobian: r.jacobian.unwrap_or_default(),
            folded: r.folded.unwrap_or_default(),
            residual: r.residual.unwrap_or_default(),
        }
    }
}

impl From<HeightResponse> for v1::HeightResponse {
    fn from(r: HeightResponse) -> Self {
        v1::HeightResponse {
            t: r.t,
            height: r.height,
        }
    }
}

impl From<BodyOrientation> for v1::BodyOrientation {
    fn from(b: BodyOrientation) -> Self {
        v1::BodyOrientation {
            heave: b.heave,
            rotation: Some(quat(b.rotation)),
            normal: Some(v3(b.normal)),
            pitch: b.pitch,
            roll: b.roll,
        }
    }
}

impl From<OrientationResponse> for v1::OrientationResponse {
    fn from(r: OrientationResponse) -> Self {
        v1::OrientationResponse {
            t: r.t,
            bodies: r.bodies.into_iter().map(Into::into).collect(),
        }
    }
}

impl From<BodyState> for v1::BodyState {
    fn from(b: BodyState) -> Self {
        v1::BodyState {
            id: b.id,
            position: Some(v3(b.position)),
            rotation: Some(quat(b.rotation)),
            velocity: Some(v3(b.velocity)),
            angular_velocity: Some(v3(b.angular_velocity)),
            submerged: b.submerged,
            quarantined: b.quarantined,
        }
    }
}

impl From<&Tick> for v1::Tick {
    fn from(t: &Tick) -> Self {
        v1::Tick {
            tick: t.tick,
            t: t.t,
            bodies: t.bodies.iter().map(|&b| b.into()).collect(),
            compact: None,
            impacts: impact_events(&t.impacts),
            anchor_tick: t.anchor_tick,
        }
    }
}

/// The protobuf form of a frame's impacts.
pub fn impact_events(events: &[crate::impacts::ImpactEvent]) -> Vec<v1::ImpactEvent> {
    events
        .iter()
        .map(|e| v1::ImpactEvent {
            tick: e.tick,
            t: e.t,
            x: e.position[0],
            z: e.position[1],
            strength: e.strength,
            radius: e.radius,
            body_tick: e.body_tick,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ApiError;

    #[test]
    fn unspecified_field_is_rejected_by_name() {
        let r = v1::SampleRequest {
            fields: vec![v1::Field::Height as i32, 0],
            ..Default::default()
        };
        let e = ApiError::from(SampleRequest::try_from(r).unwrap_err());
        assert_eq!(e.field.as_deref(), Some("fields[1]"));
        assert_eq!(e.status().as_u16(), 400);
    }

    #[test]
    fn unknown_enum_values_are_rejected_by_name() {
        let r = v1::SampleRequest {
            accuracy: Some(v1::Accuracy {
                filter: 42,
                ..Default::default()
            }),
            ..Default::default()
        };
        let e = ApiError::from(SampleRequest::try_from(r).unwrap_err());
        assert_eq!(e.field.as_deref(), Some("accuracy.filter"));
        let r = v1::SampleRequest {
            accuracy: Some(v1::Accuracy {
                precision: 7,
                ..Default::default()
            }),
            ..Default::default()
        };
        let e = ApiError::from(SampleRequest::try_from(r).unwrap_err());
        assert_eq!(e.field.as_deref(), Some("accuracy.precision"));
    }

    #[test]
    fn missing_body_position_is_rejected_by_name() {
        let r = v1::OrientationRequest {
            t: None,
            bodies: vec![v1::Body::default()],
        };
        let e = ApiError::from(OrientationRequest::try_from(r).unwrap_err());
        assert_eq!(e.field.as_deref(), Some("bodies[0].position"));
    }
}
