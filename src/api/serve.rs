//! The accept loop: HTTP/1.1 connections (WebSocket upgrades included) served by hyper, with
//! the two limits `axum::serve` has no setting for.
//!
//! - **`max_connections`**: connections open at once. At the limit the loop stops accepting;
//!   new connections wait in the kernel's listen backlog until one closes (as nginx's
//!   `worker_connections` does), so a burst of clients cannot make the server hold a connection
//!   (and its buffers, ~15 KiB) per client without bound, or run out of file descriptors.
//!   WebSocket sessions count: they are connections.
//! - **`idle_timeout_ms`**: how long a connection may wait for the next request's headers, from
//!   when it opens or its last answer was written (hyper's header read timeout). An idle
//!   keep-alive connection is closed after it, and so is a client that trickles a request's
//!   headers (slowloris). An upgraded WebSocket is not subject to it.
//!
//! Everything else is what `axum::serve` does: TCP_NODELAY, accept errors logged and retried,
//! graceful shutdown (stop accepting, let every connection finish its request in flight, close
//! idle ones at once). Open connections are published as `swell_http_connections`.

use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::{Semaphore, watch};

/// The limits of [`serve`].
#[derive(Debug, Clone, Copy)]
pub struct ConnectionLimits {
    /// Connections open at once (at least 1).
    pub max_connections: usize,
    /// Longest wait for a request's headers on an open connection; `None`: no limit.
    pub idle_timeout: Option<Duration>,
}

/// Serves `app` on `listener` until `shutdown` completes, then stops accepting and waits for
/// every connection to finish (idle ones close at once; a request in flight runs to its end).
///
/// # Errors
/// None today: accept errors are logged and retried (a full file table eases as connections
/// close). The `Result` keeps the shape of `axum::serve`.
pub async fn serve(
    listener: TcpListener,
    app: Router,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let slots = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    // Dropping `stop_rx` tells every connection to shut down gracefully; every connection task
    // holds a `done_rx`, so `done_tx.closed()` completes when the last one ends.
    let (stop_tx, stop_rx) = watch::channel(());
    let (done_tx, done_rx) = watch::channel(());
    tokio::spawn(async move {
        shutdown.await;
        drop(stop_rx);
    });
    let open = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    loop {
        let permit = tokio::select! {
            p = slots.clone().acquire_owned() => match p {
                Ok(p) => p,
                Err(_) => break, // never closed
            },
            () = stop_tx.closed() => break,
        };
        let (tcp, remote) = tokio::select! {
            r = listener.accept() => match r {
                Ok(conn) => conn,
                Err(e) => {
                    accept_error(&e).await;
                    continue;
                }
            },
            () = stop_tx.closed() => break,
        };
        if let Err(e) = tcp.set_nodelay(true) {
            tracing::debug!(error = %e, "could not set TCP_NODELAY");
        }
        let service = TowerToHyperService::new(app.clone());
        let (stop, done, open) = (stop_tx.clone(), done_rx.clone(), open.clone());
        tokio::spawn(async move {
            let n = open.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            #[allow(clippy::cast_precision_loss)]
            metrics::gauge!("swell_http_connections").set(n as f64);
            let mut builder = hyper::server::conn::http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(limits.idle_timeout);
            let conn = builder
                .serve_connection(TokioIo::new(tcp), service)
                .with_upgrades();
            let mut conn = std::pin::pin!(conn);
            tokio::select! {
                r = conn.as_mut() => log_end(r, remote),
                () = stop.closed() => {
                    conn.as_mut().graceful_shutdown();
                    log_end(conn.await, remote);
                }
            }
            let n = open.fetch_sub(1, std::sync::atomic::Ordering::Relaxed) - 1;
            #[allow(clippy::cast_precision_loss)]
            metrics::gauge!("swell_http_connections").set(n as f64);
            drop(permit);
            drop(done);
        });
    }
    drop(listener);
    drop(done_rx);
    done_tx.closed().await;
    Ok(())
}

fn log_end(r: Result<(), hyper::Error>, remote: std::net::SocketAddr) {
    if let Err(e) = r {
        // A client that went away, a malformed request or the idle timeout: the connection's
        // business, not the server's.
        tracing::trace!(%remote, error = %e, "connection ended");
    }
}

/// What `axum::serve` does with an accept error: a connection that failed before it was
/// accepted is skipped; anything else (out of file descriptors, out of memory) waits a moment
/// for resources to free up.
async fn accept_error(e: &std::io::Error) {
    use std::io::ErrorKind::{ConnectionAborted, ConnectionRefused, ConnectionReset};
    if matches!(
        e.kind(),
        ConnectionRefused | ConnectionAborted | ConnectionReset
    ) {
        return;
    }
    tracing::error!(error = %e, "accept failed; retrying in 1 s");
    tokio::time::sleep(Duration::from_secs(1)).await;
}
