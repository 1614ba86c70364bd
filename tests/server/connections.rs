//! The accept loop's two limits over real sockets: `max_connections` (beyond it a connection
//! waits, unserved, until another closes, a WebSocket included) and `idle_timeout_ms` (an idle keep-alive connection,
//! or one that never sends a request, is closed; a WebSocket is not).

use crate::common;

use std::time::{Duration, Instant};

use common::{TestServer, config};
use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

fn limited(max_connections: usize, idle_timeout_ms: u64) -> swell::Config {
    let mut c = config();
    c.limits.max_connections = max_connections;
    c.limits.idle_timeout_ms = idle_timeout_ms;
    c
}

const HEALTHZ: &[u8] = b"GET /healthz HTTP/1.1\r\nhost: swell\r\n\r\n";

/// Sends `GET /healthz` and reads until the answer's status line and headers are in.
/// `swell_http_connections` is one gauge for the whole process, and every test here opens and
/// closes connections: they take turns, or one test's closes land inside another's reading
/// (seen: `open_connections_are_published` read 2 → 6 for five new connections).
static ONE_AT_A_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

async fn healthz(tcp: &mut TcpStream, within: Duration) -> Option<String> {
    tcp.write_all(HEALTHZ).await.ok()?;
    read_answer(tcp, within).await
}

async fn read_answer(tcp: &mut TcpStream, within: Duration) -> Option<String> {
    let mut got = Vec::new();
    let deadline = Instant::now() + within;
    let mut buf = [0u8; 4096];
    while !String::from_utf8_lossy(&got).contains("\r\n\r\n") {
        let left = deadline.checked_duration_since(Instant::now())?;
        match tokio::time::timeout(left, tcp.read(&mut buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) | Err(_) => return None,
            Ok(Ok(n)) => got.extend_from_slice(&buf[..n]),
        }
    }
    Some(String::from_utf8_lossy(&got).into_owned())
}

/// Whether the server closes `tcp` (reads end of stream or a reset) within `within`.
async fn closed_within(tcp: &mut TcpStream, within: Duration) -> bool {
    let mut buf = [0u8; 256];
    matches!(
        tokio::time::timeout(within, tcp.read(&mut buf)).await,
        Ok(Ok(0)) | Ok(Err(_))
    )
}

async fn open_connections(s: &TestServer) -> f64 {
    let text = s.get("/metrics").await.text().await.unwrap();
    common::metric(&text, "swell_http_connections").unwrap_or(f64::NAN)
}

/// With every place under `max_connections` taken: a new connection gets in (the kernel's listen
/// backlog takes it) but is not served within 0.5 s, and is served once `free` gives a place back.
async fn waits_until_freed(s: &TestServer, free: impl FnOnce(), held: &str) {
    let mut c = TcpStream::connect(s.addr).await.unwrap();
    assert_eq!(
        healthz(&mut c, Duration::from_millis(500)).await,
        None,
        "served {held}"
    );
    free();
    let answer = read_answer(&mut c, Duration::from_secs(5))
        .await
        .expect("served once a place was given back");
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
}

#[tokio::test]
async fn beyond_max_connections_a_connection_waits_until_another_closes() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let s = TestServer::start(limited(2, 60_000)).await;
    let mut a = TcpStream::connect(s.addr).await.unwrap();
    let mut b = TcpStream::connect(s.addr).await.unwrap();
    for c in [&mut a, &mut b] {
        let answer = healthz(c, Duration::from_secs(5)).await.expect("answered");
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    }
    waits_until_freed(&s, || drop(a), "beyond max_connections").await;
    drop(b);
    s.stop().await;
}

/// A connection upgraded to a WebSocket keeps its place under `max_connections` until the session
/// ends (hyper hands the socket on at the upgrade; the place goes with the socket).
#[tokio::test]
async fn a_websocket_holds_its_connection_slot_until_it_closes() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let s = TestServer::start(limited(2, 60_000)).await;
    let url = format!("ws://{}/v1/scenes/calm/stream", s.addr);
    let (ws, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    let mut b = TcpStream::connect(s.addr).await.unwrap();
    assert!(healthz(&mut b, Duration::from_secs(5)).await.is_some());
    waits_until_freed(
        &s,
        || drop(ws),
        "while a WebSocket and a connection held both places",
    )
    .await;
    drop(b);
    s.stop().await;
}

#[tokio::test]
async fn idle_connections_are_closed_after_the_idle_timeout_and_busy_ones_are_not() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let s = TestServer::start(limited(100, 400)).await;
    // Kept busy: a request every 150 ms for 1.2 s, three idle timeouts' worth.
    let mut busy = TcpStream::connect(s.addr).await.unwrap();
    // Idle after one answer.
    let mut idle = TcpStream::connect(s.addr).await.unwrap();
    assert!(healthz(&mut idle, Duration::from_secs(5)).await.is_some());
    // Never sends anything.
    let mut silent = TcpStream::connect(s.addr).await.unwrap();
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(1200) {
        let answer = healthz(&mut busy, Duration::from_secs(5)).await;
        assert!(
            answer.is_some_and(|a| a.starts_with("HTTP/1.1 200")),
            "a busy connection was cut after {:?}",
            start.elapsed()
        );
        tokio::time::sleep(Duration::from_millis(150)).await;
    }
    assert!(
        closed_within(&mut idle, Duration::from_secs(2)).await,
        "idle one open"
    );
    assert!(
        closed_within(&mut silent, Duration::from_secs(2)).await,
        "silent one open"
    );
    // A WebSocket stays open past the timeout with nothing sent either way, and still answers.
    let url = format!("ws://{}/v1/scenes/calm/stream", s.addr);
    let (mut ws, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    tokio::time::sleep(Duration::from_millis(1000)).await;
    ws.send(tungstenite::Message::text(
        r#"{"type":"ping","id":1,"client_time":0}"#,
    ))
    .await
    .expect("the WebSocket is still open");
    let reply = tokio::time::timeout(Duration::from_secs(5), ws.next())
        .await
        .expect("an answer")
        .expect("a message")
        .expect("not an error");
    assert!(reply.is_text(), "{reply:?}");
    drop(ws);
    s.stop().await;
}

/// Issue 27: a client that started a request and trickled its headers was closed without a
/// word when the idle timeout (60 s) ran out. A head now has `head_timeout_ms` from its first
/// byte: then 408 `request_timeout` with the JSON error, and the connection closes. Idle
/// keep-alive connections (no head started), busy ones and WebSockets are not touched by it.
#[tokio::test]
async fn a_head_that_does_not_arrive_in_time_is_answered_408() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let mut c = limited(100, 60_000);
    c.limits.head_timeout_ms = 400;
    let s = TestServer::start(c).await;
    // A head trickled a byte every 100 ms: past 400 ms, 408 and the end of the connection.
    let slow = TcpStream::connect(s.addr).await.unwrap();
    let (mut rd, mut wr) = slow.into_split();
    let start = Instant::now();
    wr.write_all(b"GET /healthz HTTP/1.1\r\nhost: swell\r\n")
        .await
        .unwrap();
    let trickle = async {
        for b in b"x-slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa" {
            if wr.write_all(&[*b]).await.is_err() {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    };
    let mut answer = Vec::new();
    let read = async {
        let _ = tokio::time::timeout(Duration::from_secs(5), rd.read_to_end(&mut answer)).await;
        start.elapsed()
    };
    let ((), took) = tokio::join!(trickle, read);
    let answer = String::from_utf8_lossy(&answer).into_owned();
    assert!(answer.starts_with("HTTP/1.1 408"), "{answer:?}");
    assert!(answer.contains("\"code\":\"request_timeout\""), "{answer}");
    assert!(answer.contains("head_timeout_ms"), "{answer}");
    assert!(
        took >= Duration::from_millis(400) && took < Duration::from_secs(3),
        "{took:?}"
    );

    // Idle after an answer for 2.5 head timeouts: still open and serving.
    let mut idle = TcpStream::connect(s.addr).await.unwrap();
    assert!(healthz(&mut idle, Duration::from_secs(5)).await.is_some());
    tokio::time::sleep(Duration::from_millis(1000)).await;
    let again = healthz(&mut idle, Duration::from_secs(5)).await;
    assert!(again.is_some_and(|a| a.starts_with("HTTP/1.1 200")));
    // Busy: a request every 150 ms for 1.2 s.
    let mut busy = TcpStream::connect(s.addr).await.unwrap();
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(1200) {
        let a = healthz(&mut busy, Duration::from_secs(5)).await;
        assert!(a.is_some_and(|a| a.starts_with("HTTP/1.1 200")));
        tokio::time::sleep(Duration::from_millis(150)).await;
    }
    // A WebSocket: its frames are not heads.
    let url = format!("ws://{}/v1/scenes/calm/stream", s.addr);
    let (mut ws, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    for i in 0..4 {
        ws.send(tungstenite::Message::text(format!(
            r#"{{"type":"ping","id":{i},"client_time":0}}"#
        )))
        .await
        .expect("the WebSocket is open");
        let reply = tokio::time::timeout(Duration::from_secs(5), ws.next())
            .await
            .expect("an answer")
            .expect("a message")
            .expect("not an error");
        assert!(reply.is_text(), "{reply:?}");
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
    s.stop().await;
}

/// Issue 27: the head timer armed at the first byte read while no request was being answered,
/// so the tail of a body that hyper drained after an early reject (here a 401: the upload has
/// no token) armed it, and a client that then went quiet was written a 408 for a request it
/// never started. Now the body's undelivered bytes are known not to be a head: the connection
/// stays open and quiet, and serves the next request, whose slow head still gets its 408.
///
/// The client sends its body without waiting for `100 Continue` (as many do), and the head is
/// padded to exactly 8 KiB, hyper's first read, so the body is not read with it; hyper reads no
/// body before the answer when `100 Continue` is expected, so it drains the body from the
/// socket after the 401: the read that used to arm the timer.
#[tokio::test]
async fn a_drained_body_after_an_early_reject_is_not_a_slow_head() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let mut c = limited(100, 60_000);
    c.limits.head_timeout_ms = 300;
    let s = TestServer::start(c).await;
    let mut tcp = rejected_upload(
        s.addr,
        "content-length: 64\r\nexpect: 100-continue",
        &[b'x'; 64],
    )
    .await;
    // Still open: the next request is served on it.
    let a = healthz(&mut tcp, Duration::from_secs(5)).await;
    assert!(a.is_some_and(|a| a.starts_with("HTTP/1.1 200")));
    // And a slow head on it is still answered 408.
    slow_head_gets_408(tcp).await;
    s.stop().await;
}

/// Sends an upload without a token (a PUT whose head, with `framing`'s headers, is padded to
/// exactly 8 KiB, hyper's first read, so `body` is not read with it), and checks the 401 and
/// then nothing for four head timeouts (300 ms): the connection is idle, not in a head.
async fn rejected_upload(addr: std::net::SocketAddr, framing: &str, body: &[u8]) -> TcpStream {
    let start = format!(
        "PUT /v1/scenes/upload HTTP/1.1\r\nhost: swell\r\ncontent-type: application/json\r\n{framing}\r\nx-pad: "
    );
    let end = "\r\n\r\n";
    let pad = "p".repeat(8192 - start.len() - end.len());
    let mut request = format!("{start}{pad}{end}").into_bytes();
    assert_eq!(request.len(), 8192);
    request.extend_from_slice(body);
    let mut tcp = TcpStream::connect(addr).await.unwrap();
    tcp.write_all(&request).await.unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    let quiet_until = Instant::now() + Duration::from_millis(1200);
    while let Some(left) = quiet_until.checked_duration_since(Instant::now()) {
        match tokio::time::timeout(left, tcp.read(&mut buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) => break,
            Ok(Ok(n)) => got.extend_from_slice(&buf[..n]),
            Err(_) => {}
        }
    }
    let got = String::from_utf8_lossy(&got).into_owned();
    assert!(got.starts_with("HTTP/1.1 401"), "{got:?}");
    assert!(
        !got.contains("408"),
        "a 408 after the drained body: {got:?}"
    );
    tcp
}

/// Trickles a head on `tcp` and checks it is answered 408 within the head timeout, well before
/// the idle timeout.
async fn slow_head_gets_408(mut tcp: TcpStream) {
    let begun = Instant::now();
    tcp.write_all(b"GET /healthz HTTP/1.1\r\n").await.unwrap();
    let mut rest = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(5), tcp.read_to_end(&mut rest)).await;
    let rest = String::from_utf8_lossy(&rest).into_owned();
    assert!(
        rest.contains("HTTP/1.1 408"),
        "{:?} after {:?}",
        rest,
        begun.elapsed()
    );
    assert!(
        begun.elapsed() < Duration::from_secs(3),
        "{:?}",
        begun.elapsed()
    );
}

/// The same with a chunked body (sent with its head, no `100 Continue` asked: with one, hyper
/// closes the connection after an early answer instead of draining a chunked body). Its length
/// is not known when the 401 goes out, so the server took every byte after it for the body's
/// tail until the next head completed, and a slow head after a drained chunked body had only
/// the idle timeout (60 s). The tail now ends at the first read that finds the socket empty
/// (hyper drains only what is at hand): the connection stays quiet, serves the next request,
/// and a slow head after that is answered 408.
#[tokio::test]
async fn a_drained_chunked_body_is_not_a_slow_head_and_the_next_slow_head_is() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let mut c = limited(100, 60_000);
    c.limits.head_timeout_ms = 300;
    let s = TestServer::start(c).await;
    let chunked = format!("40\r\n{}\r\n0\r\n\r\n", "x".repeat(64));
    // The connection is open and serves the next request.
    let mut tcp = rejected_upload(s.addr, "transfer-encoding: chunked", chunked.as_bytes()).await;
    let a = healthz(&mut tcp, Duration::from_secs(5)).await;
    assert!(a.is_some_and(|a| a.starts_with("HTTP/1.1 200")));
    // The first head after the drained body, trickled: 408 within the head timeout.
    let tcp = rejected_upload(s.addr, "transfer-encoding: chunked", chunked.as_bytes()).await;
    slow_head_gets_408(tcp).await;
    s.stop().await;
}

#[tokio::test]
async fn open_connections_are_published() {
    let _turn = ONE_AT_A_TIME.lock().await;
    let s = TestServer::start(limited(100, 60_000)).await;
    let before = open_connections(&s).await;
    let mut held = Vec::new();
    for _ in 0..5 {
        let mut c = TcpStream::connect(s.addr).await.unwrap();
        assert!(healthz(&mut c, Duration::from_secs(5)).await.is_some());
        held.push(c);
    }
    let during = open_connections(&s).await;
    assert!(during >= before + 5.0, "{before} → {during}");
    drop(held);
    // The server notices the closes on its next read.
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let now = open_connections(&s).await;
        if now <= during - 5.0 {
            break;
        }
        assert!(Instant::now() < deadline, "still {now} open");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    s.stop().await;
}
