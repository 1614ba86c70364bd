//! `swell healthcheck`: asks a running server's `/healthz` (or any URL) over plain HTTP/1.1 and
//! succeeds on a 2xx. For container `HEALTHCHECK`s: the runtime image has no curl, and the
//! binary is already there.

use std::time::Duration;

use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
use tokio::net::TcpStream;

/// The URL checked when none is given: the server's own liveness endpoint on its default port.
pub const DEFAULT_URL: &str = "http://127.0.0.1:8080/healthz";

/// Largest answer head read, bytes: the status line is all that is needed.
const MAX_HEAD: usize = 4096;

/// Why a check failed.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The URL is not `http://HOST:PORT/PATH`.
    #[error("--url {0:?}: expected http://HOST[:PORT]/PATH (plain HTTP)")]
    BadUrl(String),
    /// Connecting, writing or reading failed.
    #[error("{url}: {source}")]
    Io {
        /// The URL.
        url: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// No answer within the timeout.
    #[error("{0}: no answer within the timeout")]
    Timeout(String),
    /// The answer was not HTTP.
    #[error("{0}: the answer is not HTTP")]
    NotHttp(String),
    /// A status other than 2xx.
    #[error("{url}: status {status}")]
    Status {
        /// The URL.
        url: String,
        /// The status code.
        status: u16,
    },
}

/// Splits `http://host[:port][/path]` into `(host:port, host, path)`.
fn split(url: &str) -> Option<(String, String, String)> {
    let rest = url.strip_prefix("http://")?;
    let (authority, path) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, "/"),
    };
    if authority.is_empty() || authority.contains('@') {
        return None;
    }
    // `[::1]:8080`, `host:8080`, or a host alone (port 80).
    let has_port = match authority.rfind(':') {
        Some(i) => !authority[i..].contains(']'),
        None => false,
    };
    let addr = if has_port {
        authority.to_owned()
    } else {
        format!("{authority}:80")
    };
    Some((addr, authority.to_owned(), path.to_owned()))
}

/// GETs `url` and returns its status if it is 2xx.
///
/// # Errors
/// A malformed URL, a connection or I/O failure, no answer within `timeout`, or a non-2xx
/// status.
pub async fn check(url: &str, timeout: Duration) -> Result<u16, CheckError> {
    let (addr, host, path) = split(url).ok_or_else(|| CheckError::BadUrl(url.to_owned()))?;
    let io = |source| CheckError::Io {
        url: url.to_owned(),
        source,
    };
    let ask = async {
        let mut tcp = TcpStream::connect(&addr).await.map_err(io)?;
        let req = format!(
            "GET {path} HTTP/1.1\r\nHost: {host}\r\nUser-Agent: swell-healthcheck\r\nConnection: close\r\n\r\n"
        );
        tcp.write_all(req.as_bytes()).await.map_err(io)?;
        let mut head = Vec::with_capacity(256);
        let mut buf = [0u8; 512];
        while !head.windows(2).any(|w| w == b"\r\n") && head.len() < MAX_HEAD {
            let n = tcp.read(&mut buf).await.map_err(io)?;
            if n == 0 {
                break;
            }
            head.extend_from_slice(&buf[..n]);
        }
        Ok::<_, CheckError>(head)
    };
    let head = tokio::time::timeout(timeout, ask)
        .await
        .map_err(|_| CheckError::Timeout(url.to_owned()))??;
    // "HTTP/1.1 200 OK"
    let line = String::from_utf8_lossy(&head);
    let status = line
        .strip_prefix("HTTP/1.")
        .and_then(|r| r.get(2..5))
        .and_then(|s| s.parse::<u16>().ok())
        .ok_or_else(|| CheckError::NotHttp(url.to_owned()))?;
    if (200..300).contains(&status) {
        Ok(status)
    } else {
        Err(CheckError::Status {
            url: url.to_owned(),
            status,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::split;

    #[test]
    fn splits_urls() {
        assert_eq!(
            split("http://127.0.0.1:8080/healthz"),
            Some((
                "127.0.0.1:8080".into(),
                "127.0.0.1:8080".into(),
                "/healthz".into()
            ))
        );
        assert_eq!(
            split("http://swell").map(|s| (s.0, s.2)),
            Some(("swell:80".into(), "/".into()))
        );
        assert_eq!(
            split("http://[::1]:9/readyz").map(|s| s.0),
            Some("[::1]:9".into())
        );
        assert_eq!(split("https://x/"), None);
        assert_eq!(split("http:///x"), None);
    }
}
