//! JSON parsing with the path of the offending field in the error ([`from_slice`],
//! [`from_value`]): what every transport decodes JSON requests with (HTTP bodies, WebSocket
//! messages, admin bodies).

use serde::de::DeserializeOwned;

use crate::error::ApiError;

/// Parses JSON bytes into `T`, naming the path of a wrong or unknown field.
///
/// # Errors
/// 400 `bad_json` with serde's message and the field path.
pub fn from_slice<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, ApiError> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let v = serde_path_to_error::deserialize(&mut de).map_err(path_error)?;
    de.end().map_err(|e| ApiError::bad_json(e.to_string()))?;
    Ok(v)
}

/// Deserialises `T` from a JSON value, naming the path of a wrong or unknown field.
///
/// # Errors
/// 400 `bad_json` with serde's message and the field path.
pub fn from_value<T: DeserializeOwned>(v: serde_json::Value) -> Result<T, ApiError> {
    serde_path_to_error::deserialize(v).map_err(path_error)
}

fn path_error(e: serde_path_to_error::Error<serde_json::Error>) -> ApiError {
    let path = e.path().to_string();
    let message = e.inner().to_string();
    let mut field = if path == "." { String::new() } else { path };
    // serde names an unknown field only in the message; put it in the path too.
    if let Some(rest) = message.strip_prefix("unknown field `")
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
    let message = if field.is_empty() {
        message
    } else {
        format!("{field}: {message}")
    };
    ApiError::bad_json(message).with_field(field)
}
