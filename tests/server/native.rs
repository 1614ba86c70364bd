//! What the tests of the C ABI against a live server (`native_*`) share.

use std::time::{Duration, Instant};

use reqwest::Method;
use serde_json::{Value, json};
use swell_ffi::{SWELL_OK, SwellStatus, swell_last_error_message};

use crate::common::{TOKEN, TestServer};

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

/// Seeks scene `scene`'s clock, paused, into the middle of scene tick `tick` (30 Hz): every tick
/// the tests reach is stepped exactly once.
pub async fn seek_paused(s: &TestServer, scene: &str, tick: i64) {
    let t = (tick as f64 + 0.5) / 30.0;
    let (st, v) = s.put_clock(scene, &json!({"paused": true, "t": t})).await;
    assert_eq!(st, 200, "{v}");
}

/// `GET path` once its answer's `tick` is `tick` (the body world got there), within 20 s.
pub async fn at_tick(s: &TestServer, path: &str, tick: i64) -> Value {
    when_field(s, path, "tick", tick).await
}

/// `GET path` once its answer's `field` is `value`, within 20 s.
pub async fn when_field(s: &TestServer, path: &str, field: &str, value: i64) -> Value {
    let start = Instant::now();
    loop {
        let (st, v) = s.get_json(path).await;
        assert_eq!(st, 200, "{v}");
        if v[field] == json!(value) {
            return v;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "`{field}` did not reach {value}: {v}"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

/// `POST /v1/scenes/{scene}/{path}` with the admin token, answered `want`.
pub async fn post(s: &TestServer, scene: &str, path: &str, body: &Value, want: u16) -> Value {
    let (st, v) = s
        .admin(
            Method::POST,
            &format!("/v1/scenes/{scene}/{path}"),
            Some(body),
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, want, "{path}: {v}");
    v
}
