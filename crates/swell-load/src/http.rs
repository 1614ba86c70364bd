//! HTTP requests: one pooled keep-alive client per run, one request per prepared variant.

use std::time::Duration;

use reqwest::header::{ACCEPT, CONTENT_TYPE};

use crate::stats::Outcome;
use crate::wire::{Wire, error_code};
use crate::workload::{Prepared, validate};

/// The run's client: HTTP/1.1 keep-alive, no proxy (a proxy variable in the environment must not
/// redirect a loopback load test), `TCP_NODELAY`, the per-request timeout.
///
/// # Errors
/// The client could not be built (no TLS/resolver needed, so practically never).
pub fn client(timeout: Duration, pool: usize) -> reqwest::Result<reqwest::Client> {
    reqwest::Client::builder()
        .no_proxy()
        .tcp_nodelay(true)
        .pool_max_idle_per_host(pool)
        // Below the server's `idle_timeout_ms` (60 s by default): the tool drops an idle
        // connection before the server closes it, so it never sends on one the server just shut.
        .pool_idle_timeout(Duration::from_secs(30))
        .timeout(timeout)
        .connect_timeout(timeout.min(Duration::from_secs(5)))
        .build()
}

/// The tally label of a transport failure.
pub fn transport_label(e: &reqwest::Error) -> &'static str {
    if e.is_timeout() {
        "timeout"
    } else if e.is_connect() {
        "connect error"
    } else {
        "transport error"
    }
}

/// The full chain of an error's causes, for details.
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cur = e.source();
    while let Some(c) = cur {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cur = c.source();
    }
    s
}

/// Sends `p` and classifies the answer.
pub async fn send(client: &reqwest::Client, p: &Prepared, wire: Wire, check: bool) -> Outcome {
    let rb = match &p.body {
        None => client.get(&p.url),
        Some(b) => client
            .post(&p.url)
            .header(CONTENT_TYPE, wire.content_type())
            .body(b.clone()),
    }
    .header(ACCEPT, wire.content_type());
    let resp = match rb.send().await {
        Ok(r) => r,
        Err(e) => {
            return Outcome::Err {
                label: transport_label(&e).into(),
                detail: chain(&e),
            };
        }
    };
    let status = resp.status();
    let body = match resp.bytes().await {
        Ok(b) => b,
        Err(e) => {
            return Outcome::Err {
                label: transport_label(&e).into(),
                detail: chain(&e),
            };
        }
    };
    if !status.is_success() {
        let code = error_code(&body).unwrap_or_else(|| "-".into());
        return Outcome::Err {
            label: format!("{} {code}", status.as_u16()),
            detail: String::from_utf8_lossy(&body[..body.len().min(300)]).into_owned(),
        };
    }
    if check && let Err(e) = validate(p.kind, wire, &body, p.points) {
        return Outcome::Err {
            label: "invalid answer".into(),
            detail: e,
        };
    }
    Outcome::Ok {
        points: p.points,
        sent: p.body.as_ref().map_or(0, |b| b.len() as u64),
        received: body.len() as u64,
    }
}
