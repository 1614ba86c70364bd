//! A scene spec, read exactly as the server reads a scene `PUT` (its `SceneSpec::from_value` and
//! `Scene::build` in `src/scene/mod.rs`): `{"description", "tick_hz", "epoch", ...SurfaceSpec}`,
//! unknown fields rejected at every level, the surface built by the model.

use serde_json::Value;
use swell_waves::body::{MAX_TICK_HZ, MIN_TICK_HZ};
use swell_waves::{FrameMemo, SpecError, Surface, SurfaceSpec};

use crate::error::{Error, SWELL_ERR_BAD_JSON};

/// The server's default tick rate, Hz (`DEFAULT_TICK_HZ` in `src/scene/mod.rs`).
pub(crate) const DEFAULT_TICK_HZ: f64 = 30.0;
/// The server's latest scene epoch, Unix s (`MAX_EPOCH`).
pub(crate) const MAX_EPOCH: f64 = 1e11;
/// The server's longest description, bytes (`MAX_DESCRIPTION`).
pub(crate) const MAX_DESCRIPTION: usize = 4096;

/// A built scene: what a surface handle holds, shared with the body worlds made from it.
#[derive(Debug)]
pub struct Scene {
    /// The waves.
    pub surface: Surface,
    /// The spec the surface was built from.
    pub spec: SurfaceSpec,
    /// Ticks per second of scene time: the body world's step rate.
    pub tick_hz: f64,
    /// Unix time of t = 0, s, when the spec gives one.
    pub epoch: Option<f64>,
    /// FFT frames the last queries computed (queries at the same grid times reuse them).
    pub memo: FrameMemo,
}

fn bad_json(message: impl Into<String>) -> Error {
    Error::new(SWELL_ERR_BAD_JSON, message)
}

fn out_of_range(field: &str, value: f64, allowed: String) -> Error {
    Error::spec(&SpecError::OutOfRange {
        field: field.into(),
        value,
        allowed,
    })
}

impl Scene {
    /// Parses and builds a scene from the JSON text a client would `PUT` to the server.
    ///
    /// # Errors
    /// [`SWELL_ERR_BAD_JSON`] for text that is not a JSON object or has a wrongly typed or
    /// unknown field; [`crate::SWELL_ERR_INVALID_SPEC`] for a `tick_hz` outside (0, 1000], an
    /// `epoch` outside [0, 1e11], a description over 4096 bytes, or waves the model rejects.
    pub fn from_json(text: &[u8]) -> Result<Scene, Error> {
        let v: Value =
            serde_json::from_slice(text).map_err(|e| bad_json(format!("scene spec: {e}")))?;
        let Value::Object(mut map) = v else {
            return Err(bad_json("a scene spec must be a JSON object"));
        };
        let description = match map.remove("description") {
            None | Some(Value::Null) => String::new(),
            Some(Value::String(s)) => s,
            Some(_) => return Err(bad_json("description must be a string")),
        };
        let tick_hz = match map.remove("tick_hz") {
            None | Some(Value::Null) => DEFAULT_TICK_HZ,
            Some(Value::Number(n)) => n.as_f64().unwrap_or(f64::NAN),
            Some(_) => return Err(bad_json("tick_hz must be a number")),
        };
        let epoch = match map.remove("epoch") {
            None | Some(Value::Null) => None,
            Some(Value::Number(n)) => Some(n.as_f64().unwrap_or(f64::NAN)),
            Some(_) => return Err(bad_json("epoch must be a number")),
        };
        let spec: SurfaceSpec = serde_json::from_value(Value::Object(map))
            .map_err(|e| bad_json(format!("scene spec: {e}")))?;
        // The server's checks, in its order (`SceneSpec::validate`).
        if !(tick_hz.is_finite() && (MIN_TICK_HZ..=MAX_TICK_HZ).contains(&tick_hz)) {
            return Err(out_of_range(
                "tick_hz",
                tick_hz,
                format!("in [{MIN_TICK_HZ}, {MAX_TICK_HZ}] Hz"),
            ));
        }
        if let Some(e) = epoch
            && !(e.is_finite() && (0.0..=MAX_EPOCH).contains(&e))
        {
            return Err(out_of_range(
                "epoch",
                e,
                format!("Unix seconds in [0, {MAX_EPOCH}]"),
            ));
        }
        if description.len() > MAX_DESCRIPTION {
            return Err(Error::spec(&SpecError::BadLength {
                field: "description".into(),
                len: description.len(),
                allowed: format!("at most {MAX_DESCRIPTION} bytes"),
            }));
        }
        let surface = Surface::new(&spec).map_err(|e| Error::spec(&e))?;
        Ok(Scene {
            surface,
            spec,
            tick_hz,
            epoch,
            memo: FrameMemo::new(),
        })
    }

    /// Whether the scene's bodies make impacts of their own (a particle layer with
    /// `body_impacts`).
    pub fn has_body_impacts(&self) -> bool {
        self.surface
            .impact_layer()
            .is_some_and(|l| l.body_impacts().is_some())
    }
}
