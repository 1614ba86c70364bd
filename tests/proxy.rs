//! The shipped nginx config (`docker/nginx.conf`, started for real by `procs::Nginx`) in front
//! of a server: its per-client limits. Behind a proxy every client reaches the server from the
//! proxy's address, so the server's slow lane (which keys on the TCP peer) cannot single out a
//! flooding client; the proxy, where the client's own address is the peer, refuses it first.
//! The proxy's loopback exemption is left out here, so clients bound to 127.0.x.y meet the
//! limits; the server (default config) trusts the proxy and exempts loopback clients, so every
//! refusal below is the proxy's.

mod common;
// `procs` (nginx) loads `common/system.rs` again for itself, as `tests/fleet.rs` includes it.
#[allow(clippy::duplicate_mod)]
#[path = "common/procs.rs"]
mod procs;

use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};

use common::{TestServer, config};
use futures_util::StreamExt as _;
use serde_json::Value;
use tokio::net::TcpSocket;

fn client_from(addr: [u8; 4]) -> reqwest::Client {
    reqwest::Client::builder()
        .no_proxy()
        .local_address(IpAddr::V4(Ipv4Addr::from(addr)))
        .pool_max_idle_per_host(64)
        .timeout(Duration::from_secs(10))
        .build()
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_shipped_nginx_refuses_a_flooding_client_in_the_servers_error_shape() {
    let s = TestServer::start(config()).await;
    let port = s.addr.port();
    let nginx = procs::Nginx::start_limiting_loopback(&[port, port, port], &s.client).await;
    let url = format!("{}/v1/scenes/calm/height?x=1&z=2&t=0", nginx.base);
    // 3,000 requests from one address, 32 at a time: the proxy lets 1,000 through at once and
    // 500 a second after that (the server's own per-address defaults).
    let flooder = client_from([127, 0, 21, 1]);
    let started = Instant::now();
    let answers: Vec<(u16, Option<String>, String)> = futures_util::stream::iter(0..3000)
        .map(|_| {
            let (c, url) = (flooder.clone(), url.clone());
            async move {
                let r = c.get(&url).send().await.expect("an answer");
                let status = r.status().as_u16();
                let retry = r
                    .headers()
                    .get("retry-after")
                    .and_then(|v| v.to_str().ok())
                    .map(str::to_owned);
                (status, retry, r.text().await.unwrap_or_default())
            }
        })
        .buffer_unordered(32)
        .collect()
        .await;
    let took = started.elapsed().as_secs_f64();
    let ok = answers.iter().filter(|a| a.0 == 200).count();
    let refused: Vec<_> = answers.iter().filter(|a| a.0 == 429).collect();
    assert_eq!(
        ok + refused.len(),
        3000,
        "other statuses: {:?}",
        answers.iter().find(|a| a.0 != 200 && a.0 != 429)
    );
    eprintln!(
        "flood through nginx: {ok} answered, {} refused in {took:.2} s",
        refused.len()
    );
    assert!(
        (ok as f64) <= 1000.0 + 500.0 * took + 50.0,
        "{ok} answered in {took:.2} s: over the proxy's rate"
    );
    assert!(
        !refused.is_empty(),
        "nothing refused: {ok} answered in {took:.2} s"
    );
    for (_, retry, body) in refused.iter().take(5) {
        assert_eq!(retry.as_deref(), Some("1"), "Retry-After");
        let v: Value = serde_json::from_str(body).expect("a JSON error");
        assert_eq!(v["error"]["code"], "rate_limited", "{body}");
        assert!(
            v["error"]["message"]
                .as_str()
                .is_some_and(|m| m.contains("proxy")),
            "{body}"
        );
    }
    // Another client is served meanwhile; so is the flooder once its rate is back under.
    let other = client_from([127, 0, 21, 2]);
    let r = other.get(&url).send().await.unwrap();
    assert_eq!(r.status(), 200);
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert_eq!(flooder.get(&url).send().await.unwrap().status(), 200);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_shipped_nginx_holds_256_websockets_per_client() {
    let s = TestServer::start(config()).await;
    let port = s.addr.port();
    let nginx = procs::Nginx::start_limiting_loopback(&[port, port, port], &s.client).await;
    let proxy: std::net::SocketAddr = nginx.base.trim_start_matches("http://").parse().unwrap();
    let url = format!("ws://{proxy}/v1/scenes/calm/stream");
    let connect = |from: [u8; 4]| {
        let url = url.clone();
        async move {
            let sock = TcpSocket::new_v4().unwrap();
            sock.bind((Ipv4Addr::from(from), 0).into()).unwrap();
            let tcp = sock.connect(proxy).await.unwrap();
            tokio_tungstenite::client_async(url, tcp).await
        }
    };
    let mut held = Vec::new();
    for _ in 0..256 {
        let (ws, _) = connect([127, 0, 22, 1])
            .await
            .expect("within the proxy's 256");
        held.push(ws);
    }
    // The 257th from the same address: refused at the proxy, in the server's error shape.
    match connect([127, 0, 22, 1]).await {
        Err(tokio_tungstenite::tungstenite::Error::Http(r)) => {
            assert_eq!(r.status().as_u16(), 429);
            let body = String::from_utf8(r.body().clone().unwrap_or_default()).unwrap();
            let v: Value = serde_json::from_str(&body).expect("a JSON error");
            assert_eq!(v["error"]["code"], "too_many_connections", "{body}");
        }
        other => panic!("the 257th WebSocket: {other:?}"),
    }
    // Another address connects; and one of the first closing makes room.
    let (other, _) = connect([127, 0, 22, 2]).await.expect("another client");
    drop(other);
    let mut first = held.pop().unwrap();
    first.close(None).await.unwrap();
    drop(first);
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        match connect([127, 0, 22, 1]).await {
            Ok((ws, _)) => {
                held.push(ws);
                break;
            }
            Err(e) => assert!(Instant::now() < deadline, "no room after a close: {e}"),
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    drop(held);
}
