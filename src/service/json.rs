//! JSON parsing with the path of the offending field in the error ([`from_slice`],
//! [`from_value`]): what every transport decodes JSON requests with (HTTP bodies, WebSocket
//! messages, admin bodies).

use serde::de::DeserializeOwned;

/// JSON that is not of the expected shape: malformed, a wrongly typed or unknown field. The API
/// answers it as 400 `bad_json` (`crate::error` maps it).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct JsonError {
    /// serde's message; prefixed with the field path when there is one (`points[1][1]: …`).
    pub message: String,
    /// Path of the offending field; `None` for the document as a whole.
    pub field: Option<String>,
}

/// Request bodies and WebSocket messages of at least this many bytes are decoded on the
/// compute pool: a 65,536-point sample (~1.5 MB of JSON) takes ~10 ms to parse, which on a
/// reactor thread would delay every other connection that thread serves.
pub const DECODE_OFF_REACTOR_BYTES: usize = 64 * 1024;

/// Parses JSON bytes into `T`, naming the path of a wrong or unknown field.
///
/// # Errors
/// [`JsonError`] with serde's message and the field path.
pub fn from_slice<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, JsonError> {
    // Valid input, the common case, parses without tracking the path: the tracking costs about
    // as much again as the parse (a 4,096-point batch: ~7% of the server's CPU). Only input
    // that fails is parsed again, with the path, for the message; both accept the same input.
    if let Ok(v) = serde_json::from_slice(bytes) {
        return Ok(v);
    }
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let v = serde_path_to_error::deserialize(&mut de).map_err(|e| path_error(e, ""))?;
    de.end().map_err(|e| JsonError {
        message: e.to_string(),
        field: None,
    })?;
    Ok(v)
}

/// Deserialises `T` from a JSON value, naming the path of a wrong or unknown field.
///
/// # Errors
/// [`JsonError`] with serde's message and the field path.
pub fn from_value<T: DeserializeOwned>(v: serde_json::Value) -> Result<T, JsonError> {
    from_value_at(v, "")
}

/// [`from_value`] for a value that sits at path `at` in the document a client sent: the error
/// names the field from the document's root (`at` = `hull`: `hull.cells[2].volume`).
///
/// # Errors
/// [`JsonError`] with serde's message and the field path under `at`.
pub fn from_value_at<T: DeserializeOwned>(v: serde_json::Value, at: &str) -> Result<T, JsonError> {
    serde_path_to_error::deserialize(v).map_err(|e| path_error(e, at))
}

/// serde's error as a [`JsonError`], its path under `at` ("" for the document's root).
fn path_error(e: serde_path_to_error::Error<serde_json::Error>, at: &str) -> JsonError {
    let path = e.path().to_string();
    let message = e.inner().to_string();
    let mut field = if path == "." { String::new() } else { path };
    // serde names an unknown or a missing field only in the message; put it in the path too.
    if let Some(rest) = message
        .strip_prefix("unknown field `")
        .or_else(|| message.strip_prefix("missing field `"))
        && let Some(name) = rest.split('`').next()
    {
        // serde_path_to_error includes the unknown key itself in some paths (plain structs)
        // and not in others (inside internally tagged enums, which serde buffers).
        let last = field.rsplit('.').next().unwrap_or("");
        if last != name {
            field = if field.is_empty() {
                name.to_owned()
            } else {
                format!("{field}.{name}")
            };
        }
    }
    if !at.is_empty() {
        field = match field.as_str() {
            "" => at.to_owned(),
            f if f.starts_with('[') => format!("{at}{f}"),
            f => format!("{at}.{f}"),
        };
    }
    let message = if field.is_empty() {
        message
    } else {
        format!("{field}: {message}")
    };
    JsonError {
        message,
        field: (!field.is_empty()).then_some(field),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Batch {
        points: Vec<[f64; 2]>,
    }

    /// The untracked fast path and the tracked fallback answer alike: valid input parses, and
    /// input that fails still names the path of what was wrong (trailing bytes included).
    #[test]
    fn valid_input_parses_and_bad_input_names_its_path() {
        let ok: Batch = from_slice(br#"{"points": [[1, 2.5], [-3e2, 0]]}"#).unwrap();
        assert_eq!(ok.points, vec![[1.0, 2.5], [-300.0, 0.0]]);
        let e = from_slice::<Batch>(br#"{"points": [[1, 2], [3, "x"]]}"#).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("points[1][1]"), "{e:?}");
        assert!(e.message.starts_with("points[1][1]: invalid type"), "{e:?}");
        let e = from_slice::<Batch>(br#"{"points": [], "colour": 1}"#).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("colour"), "{e:?}");
        let e = from_slice::<Batch>(br#"{}"#).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("points"), "{e:?}");
        assert!(e.message.starts_with("points: missing field"), "{e:?}");
        assert!(from_slice::<Batch>(br#"{"points": []} x"#).is_err());
    }

    /// A value from inside a document is named from the document's root.
    #[test]
    fn a_value_at_a_path_names_its_fields_under_it() {
        let v = serde_json::json!({"points": [[1, 2], [3, "x"]]});
        let e = from_value_at::<Batch>(v, "batches[4]").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("batches[4].points[1][1]"), "{e:?}");
        assert!(
            e.message
                .starts_with("batches[4].points[1][1]: invalid type"),
            "{e:?}"
        );
        let e = from_value_at::<Batch>(serde_json::json!({}), "batch").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("batch.points"), "{e:?}");
        let e = from_value_at::<Batch>(serde_json::json!(3), "batch").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("batch"), "{e:?}");
    }
}
