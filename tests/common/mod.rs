//! Test harness: a real server on 127.0.0.1 with an ephemeral port, in this process.
#![allow(dead_code, unreachable_pub)]

pub mod browser;
pub mod system;

use std::net::SocketAddr;
use std::path::PathBuf;

use reqwest::{Client, Method, Response};
use serde_json::Value;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;

pub const TOKEN: &str = "test-token";

/// A config for tests: ephemeral port, fixed token, built-in scenes, no data dir.
/// Resident bytes of a process (`"self"` or a pid): `/proc/PID/statm`, second field, in pages.
pub fn resident_bytes(pid: &str) -> usize {
    let statm = std::fs::read_to_string(format!("/proc/{pid}/statm")).expect("statm");
    let pages: usize = statm
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .expect("resident pages");
    pages * 4096
}

/// Unix seconds now.
pub fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
}

/// A free loopback port for a child `swell` process: bind port 0, learn the port, release it
/// (a small race, fine in tests).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

pub fn config() -> swell::Config {
    swell::Config {
        bind: SocketAddr::from(([127, 0, 0, 1], 0)),
        admin_token: Some(TOKEN.into()),
        ..Default::default()
    }
}

pub fn config_with_dir(dir: PathBuf) -> swell::Config {
    swell::Config {
        data_dir: Some(dir),
        ..config()
    }
}

pub struct TestServer {
    pub addr: SocketAddr,
    pub client: Client,
    pub state: swell::AppState,
    /// The `--probe-bind` listener's address, when the config asked for one.
    pub probe: Option<SocketAddr>,
    stop: Option<oneshot::Sender<()>>,
    task: Option<JoinHandle<std::io::Result<()>>>,
}

impl TestServer {
    pub async fn start(config: swell::Config) -> TestServer {
        let server = swell::Server::bind(config).await.expect("server starts");
        let addr = server.local_addr();
        let probe = server.probe_addr();
        let state = server.state().clone();
        let (tx, rx) = oneshot::channel::<()>();
        let task = tokio::spawn(server.run(async move {
            let _ = rx.await;
        }));
        let client = Client::builder().no_proxy().build().expect("client");
        TestServer {
            addr,
            client,
            state,
            probe,
            stop: Some(tx),
            task: Some(task),
        }
    }

    /// Running tick loops.
    pub fn state_tickers(&self) -> usize {
        self.state.tickers.running()
    }

    pub fn url(&self, path: &str) -> String {
        format!("http://{}{}", self.addr, path)
    }

    /// Graceful shutdown; returns once the server has stopped.
    pub async fn stop(mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        if let Some(task) = self.task.take() {
            task.await
                .expect("server task")
                .expect("server ran cleanly");
        }
    }

    /// Starts a graceful shutdown without waiting for it.
    pub fn begin_stop(&mut self) -> JoinHandle<std::io::Result<()>> {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        self.task.take().expect("running")
    }

    pub async fn get(&self, path: &str) -> Response {
        self.client.get(self.url(path)).send().await.expect("GET")
    }

    pub async fn get_json(&self, path: &str) -> (u16, Value) {
        into_json(self.get(path).await).await
    }

    pub async fn post_json(&self, path: &str, body: &Value) -> (u16, Value) {
        let r = self
            .client
            .post(self.url(path))
            .json(body)
            .send()
            .await
            .expect("POST");
        into_json(r).await
    }

    pub async fn post_raw(&self, path: &str, body: &str) -> (u16, Value) {
        let r = self
            .client
            .post(self.url(path))
            .header("content-type", "application/json")
            .body(body.to_owned())
            .send()
            .await
            .expect("POST");
        into_json(r).await
    }

    /// An admin request with the right token (`token = Some(TOKEN)`), another, or none.
    pub async fn admin(
        &self,
        method: Method,
        path: &str,
        body: Option<&Value>,
        token: Option<&str>,
    ) -> (u16, Value) {
        let mut rb = self.client.request(method, self.url(path));
        if let Some(t) = token {
            rb = rb.bearer_auth(t);
        }
        if let Some(b) = body {
            rb = rb.json(b);
        }
        into_json(rb.send().await.expect("admin request")).await
    }

    pub async fn put_scene(&self, id: &str, spec: &Value) -> (u16, Value) {
        self.admin(
            Method::PUT,
            &format!("/v1/scenes/{id}"),
            Some(spec),
            Some(TOKEN),
        )
        .await
    }

    pub async fn put_clock(&self, id: &str, update: &Value) -> (u16, Value) {
        self.admin(
            Method::PUT,
            &format!("/v1/scenes/{id}/clock"),
            Some(update),
            Some(TOKEN),
        )
        .await
    }
}

pub async fn into_json(r: Response) -> (u16, Value) {
    let status = r.status().as_u16();
    let text = r.text().await.expect("body");
    let v = if text.is_empty() {
        Value::Null
    } else {
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("not JSON ({e}): {text}"))
    };
    (status, v)
}

/// The value of an unlabelled metric in a Prometheus text page (`name value` on its own line).
pub fn metric(page: &str, name: &str) -> Option<f64> {
    page.lines()
        .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
}

/// f64 bits of a JSON number.
pub fn bits(v: &Value) -> u64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("not a number: {v}"))
        .to_bits()
}

/// The error code of an error body.
pub fn code(v: &Value) -> &str {
    v["error"]["code"]
        .as_str()
        .unwrap_or_else(|| panic!("not an error: {v}"))
}

/// A small Gerstner scene spec.
pub fn small_spec() -> Value {
    serde_json::json!({
        "description": "test sea",
        "tick_hz": 20,
        "seed": 3,
        "layers": [
            {"kind": "gerstner", "waves": [
                {"amplitude": 0.4, "wavelength": 30, "direction": [1, 0.5], "steepness": 0.6},
                {"amplitude": 0.1, "wavelength": 9, "direction": [-0.2, 1], "steepness": 0.4, "phase": 0.3}
            ]}
        ]
    })
}

/// A small FFT scene spec (64², cheap frames).
pub fn fft_spec() -> Value {
    serde_json::json!({
        "description": "small fft",
        "seed": 11,
        "layers": [
            {"kind": "fft", "resolution": 64, "tile_size": 64, "choppiness": 1.0, "repeat_period": 100,
             "wind_direction": [1, 0.2],
             "spectrum": {"kind": "jonswap", "wind_speed": 8, "fetch": 50000}},
            {"kind": "sine", "waves": [{"amplitude": 0.05, "wavelength": 5, "direction": [0, 1]}]}
        ]
    })
}

pub type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Opens `/v1/scenes/{scene}/stream`, offering `protocol` if given. Panics if the upgrade fails.
pub async fn ws_connect(addr: SocketAddr, scene: &str, protocol: Option<&str>) -> Ws {
    ws_try_connect(addr, scene, protocol)
        .await
        .unwrap_or_else(|e| panic!("upgrade failed: {e}"))
}

/// As [`ws_connect`], returning the handshake error.
pub async fn ws_try_connect(
    addr: SocketAddr,
    scene: &str,
    protocol: Option<&str>,
) -> Result<Ws, tokio_tungstenite::tungstenite::Error> {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let mut req = format!("ws://{addr}/v1/scenes/{scene}/stream")
        .into_client_request()
        .expect("request");
    if let Some(p) = protocol {
        req.headers_mut()
            .insert("sec-websocket-protocol", p.parse().expect("header"));
    }
    tokio_tungstenite::connect_async(req)
        .await
        .map(|(ws, _)| ws)
}
