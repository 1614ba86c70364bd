//! Determinism across processes: the `swell` binary, started as a separate OS process with the
//! same (built-in) scenes, answers bit for bit what an in-process server answers.

use crate::common;

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{TestServer, bits, config, free_port};
use serde_json::{Value, json};

/// Kills the child process when the test ends, pass or fail.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `swell serve` as a separate process on a free loopback port with its own data dir, once it
/// answers `/readyz`; the base URL, the child (killed on drop) and the data dir.
async fn spawn_server(client: &reqwest::Client) -> (String, Killed, tempfile::TempDir) {
    let port = free_port();
    let dir = tempfile::tempdir().unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_swell"))
        .args(["serve", "--bind", &format!("127.0.0.1:{port}")])
        .arg("--data-dir")
        .arg(dir.path())
        .args(["--admin-token", "x"])
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the swell binary starts");
    let guard = Killed(child);
    let base = format!("http://127.0.0.1:{port}");
    let start = Instant::now();
    loop {
        if let Ok(r) = client.get(format!("{base}/readyz")).send().await
            && r.status() == 200
        {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the child never became ready"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    (base, guard, dir)
}

#[tokio::test]
async fn a_second_server_process_answers_the_same_bits() {
    let client = reqwest::Client::builder().no_proxy().build().unwrap();
    let (base, _guard, _dir) = spawn_server(&client).await;
    let here = TestServer::start(config()).await;
    let body = json!({"t": 1234.5678, "origin": [1e6, -2e6],
        "points": [[0.0, 0.0], [13.25, -7.5], [250.0, 999.0]],
        "fields": ["height", "normal", "displacement", "jacobian", "residual"]});
    for scene in ["calm", "lake", "open-sea", "storm"] {
        let path = format!("/v1/scenes/{scene}/sample");
        let (st, ours) = here.post_json(&path, &body).await;
        assert_eq!(st, 200, "{ours}");
        let theirs: Value = client
            .post(format!("{base}{path}"))
            .json(&body)
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        for field in ["height", "jacobian", "residual"] {
            let (a, b) = (
                ours[field].as_array().unwrap(),
                theirs[field].as_array().unwrap(),
            );
            assert_eq!(a.len(), b.len());
            for (x, y) in a.iter().zip(b) {
                assert_eq!(bits(x), bits(y), "{scene}.{field}: {x} vs {y}");
            }
        }
        for field in ["normal", "displacement"] {
            let (a, b) = (
                ours[field].as_array().unwrap(),
                theirs[field].as_array().unwrap(),
            );
            for (x, y) in a.iter().zip(b) {
                for i in 0..3 {
                    assert_eq!(bits(&x[i]), bits(&y[i]), "{scene}.{field}: {x} vs {y}");
                }
            }
        }
    }
    here.stop().await;
}

/// A stream subscriber costs the server tens of kilobytes, not the 128 KiB read buffer
/// tungstenite allocates per socket by default and zeroes before every read (1,000
/// subscribers held 152 MiB; `stream::WS_READ_BUFFER_BYTES`). Measured on a separate server
/// process, so the clients' own buffers do not count.
#[cfg(target_os = "linux")]
#[tokio::test]
async fn a_stream_subscriber_costs_the_server_well_under_128_kib() {
    use futures_util::SinkExt as _;
    const SUBSCRIBERS: usize = 200;
    let client = reqwest::Client::builder().no_proxy().build().unwrap();
    let (base, guard, _dir) = spawn_server(&client).await;
    let pid = guard.0.id().to_string();
    let addr: std::net::SocketAddr = base.trim_start_matches("http://").parse().unwrap();
    // One connection first, so the server's first-use allocations are not counted.
    let mut first = common::ws_connect(addr, "calm", None).await;
    first
        .send(tungstenite::Message::text(
            json!({"type": "subscribe", "ticks": true}).to_string(),
        ))
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let before = common::resident_bytes(&pid);
    let mut all = Vec::with_capacity(SUBSCRIBERS);
    for _ in 0..SUBSCRIBERS {
        let mut ws = common::ws_connect(addr, "calm", None).await;
        ws.send(tungstenite::Message::text(
            json!({"type": "subscribe", "ticks": true}).to_string(),
        ))
        .await
        .unwrap();
        all.push(ws);
    }
    // Every session has read its subscribe (its socket's read buffer touched) and sent ticks.
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let per = common::resident_bytes(&pid).saturating_sub(before) / SUBSCRIBERS;
    eprintln!("{per} bytes resident per subscriber ({SUBSCRIBERS} subscribers)");
    assert!(
        per < 64 * 1024,
        "{per} bytes resident per subscriber ({SUBSCRIBERS} subscribers)"
    );
    drop(all);
}

/// A blank `--admin-token` (an unset shell variable expanded to `""` or spaces) would be a
/// token anyone can guess: the server refuses to start and says why.
#[test]
fn a_blank_admin_token_stops_startup() {
    let dir = tempfile::tempdir().unwrap();
    for token in ["", "   "] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_swell"))
            .args(["serve", "--bind", "127.0.0.1:0", "--admin-token", token])
            .arg("--data-dir")
            .arg(dir.path())
            .env_remove("SWELL_ADMIN_TOKEN")
            .output()
            .unwrap();
        assert!(!out.status.success(), "{token:?} started");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("empty or blank"), "{token:?}: {err}");
    }
}
