//! The protobuf form of an [`ApiError`]: the same code, message and field as the JSON body
//! (`ApiError`'s `IntoResponse`), for protobuf HTTP answers (`api::wire`) and protobuf
//! WebSocket `error` messages (`stream`).

use super::ApiError;
use crate::wire::v1;

impl From<&ApiError> for v1::Error {
    fn from(e: &ApiError) -> Self {
        v1::Error {
            code: e.code.as_str().to_owned(),
            message: e.message.clone(),
            field: e.field.clone(),
        }
    }
}

impl From<&ApiError> for v1::ErrorResponse {
    fn from(e: &ApiError) -> Self {
        v1::ErrorResponse {
            error: Some(e.into()),
        }
    }
}
