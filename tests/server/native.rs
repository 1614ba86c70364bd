//! What the tests of the C ABI against a live server (`native_*`) share.

use serde_json::Value;
use swell_ffi::{SWELL_OK, SwellStatus, swell_last_error_message};

/// This thread's last C ABI error message.
pub fn status_message() -> String {
    // SAFETY: the message is a NUL-terminated string owned by this thread's last error.
    unsafe { std::ffi::CStr::from_ptr(swell_last_error_message()) }
        .to_string_lossy()
        .into_owned()
}

/// Asserts a C ABI call succeeded, with its message if not.
pub fn ok(status: SwellStatus) {
    assert_eq!(status, SWELL_OK, "status {status}: {}", status_message());
}

/// A JSON array of `N` numbers.
pub fn arr<const N: usize>(v: &Value) -> [f64; N] {
    let a = v.as_array().unwrap_or_else(|| panic!("not an array: {v}"));
    assert_eq!(a.len(), N, "{v}");
    std::array::from_fn(|i| a[i].as_f64().unwrap())
}
