//! Headless Chromium for the browser tests (Debian's `chromium`, or `$CHROMIUM`), two ways:
//!
//! - WebGL2 ([`run_webgl_page`]): a page written to a file runs on SwiftShader's WebGL2 and
//!   leaves its result as JSON in `<pre id="out">`, which `--dump-dom` prints.
//! - WebGPU ([`run_webgpu_page`]): WebGPU needs a secure origin and is asynchronous, so the page
//!   is served from `http://127.0.0.1` by the test and POSTs its result back to it.

use std::process::Command;

use serde_json::{Value, json};

/// The Chromium binary: `$CHROMIUM`, else Debian's `chromium` (installed when missing, see
/// `system.rs`).
pub fn chromium() -> String {
    std::env::var("CHROMIUM").unwrap_or_else(|_| {
        super::system::program("chromium", "chromium")
            .display()
            .to_string()
    })
}

/// `s` with the five entities `--dump-dom` writes turned back into characters.
pub fn unescape_html(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&#39;", "'")
        .replace("&amp;", "&")
}

/// Runs `script` in a page `{name}.html` (after `<pre id="out">pending</pre>`) in headless
/// Chromium with WebGL2 on SwiftShader, killed after `timeout_s` seconds, with a virtual-time
/// budget of `budget_ms`. Returns the JSON the script wrote into `#out`; panics (with Chromium's
/// stderr) when there is none, and when it does not say `"ok": true`.
pub fn run_webgl_page(name: &str, script: &str, timeout_s: u32, budget_ms: u32) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join(format!("{name}.html"));
    std::fs::write(
        &page,
        format!(
            "<!doctype html><html><body><pre id=\"out\">pending</pre><script>\n{script}</script></body></html>"
        ),
    )
    .unwrap();
    let output = Command::new("timeout")
        .arg(timeout_s.to_string())
        .arg(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-dev-shm-usage",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--ignore-gpu-blocklist",
            "--no-first-run",
        ])
        .arg(format!("--virtual-time-budget={budget_ms}"))
        .arg(format!(
            "--user-data-dir={}",
            dir.path().join("profile").display()
        ))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs (set CHROMIUM to its path)");
    let dom = String::from_utf8_lossy(&output.stdout);
    let Some(start) = dom.find("<pre id=\"out\">") else {
        panic!(
            "no result in the DOM; chromium status {:?}, stderr:\n{}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
    };
    let rest = &dom[start + "<pre id=\"out\">".len()..];
    let body = unescape_html(&rest[..rest.find("</pre>").unwrap()]);
    let result: Value = serde_json::from_str(&body)
        .unwrap_or_else(|e| panic!("page result is not JSON ({e}): {body}"));
    assert_eq!(result["ok"], json!(true), "page failed: {result}");
    result
}

/// Serves `page` at `http://127.0.0.1:PORT/` (WebGPU needs a secure origin: a file is not
/// one, loopback HTTP is) and hands the body POSTed to `/result` to the receiver.
async fn serve_page(
    page: String,
) -> (
    std::net::SocketAddr,
    tokio::sync::mpsc::Receiver<String>,
    tokio::task::JoinHandle<()>,
) {
    use axum::routing::{get, post};
    let (tx, rx) = tokio::sync::mpsc::channel::<String>(1);
    let app = axum::Router::new()
        .route(
            "/",
            get(move || {
                let page = page.clone();
                async move { axum::response::Html(page) }
            }),
        )
        .route(
            "/result",
            post(move |body: String| {
                let tx = tx.clone();
                async move {
                    let _ = tx.send(body).await;
                    axum::http::StatusCode::NO_CONTENT
                }
            }),
        );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let task = tokio::spawn(async move {
        let _ = axum::serve(listener, app).await;
    });
    (addr, rx, task)
}

/// Runs `script` (which must POST its JSON result to `/result`, `{"unavailable": why}` where
/// the page finds no WebGPU adapter) in a page on loopback HTTP, in headless Chromium with
/// SwiftShader's WebGPU adapter, profile and log under `dir`; panics when no result arrives in
/// `timeout_s` seconds. `Err` with the reason when this Chromium offers no WebGPU adapter.
///
/// The flags: `--enable-unsafe-webgpu --use-webgpu-adapter=swiftshader` give headless Chromium
/// an adapter here; `--enable-features=Vulkan --use-vulkan=swiftshader` put the rest of the GPU
/// process on the same SwiftShader Vulkan (without them a presented canvas loses the device,
/// see docs/clients.md; compute-only pages ran either way).
pub async fn run_webgpu_page(
    dir: &std::path::Path,
    script: &str,
    timeout_s: u64,
) -> Result<Value, String> {
    let page = format!(
        "<!doctype html><html><body><pre id=\"out\">pending</pre><script>\n{script}</script></body></html>"
    );
    let (addr, mut rx, server) = serve_page(page).await;
    let log = dir.join("chromium-webgpu.log");
    let mut child = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-dev-shm-usage",
            "--enable-unsafe-webgpu",
            "--use-webgpu-adapter=swiftshader",
            "--enable-features=Vulkan",
            "--use-vulkan=swiftshader",
            "--enable-unsafe-swiftshader",
            "--ignore-gpu-blocklist",
            "--no-first-run",
            "--no-default-browser-check",
            "--disable-background-networking",
            "--disable-extensions",
        ])
        .arg(format!(
            "--user-data-dir={}",
            dir.join("profile-webgpu").display()
        ))
        .arg(format!("http://{addr}/"))
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .expect("chromium runs (set CHROMIUM to its path)");
    let got = tokio::time::timeout(std::time::Duration::from_secs(timeout_s), rx.recv()).await;
    // Chromium does not exit by itself with a page open: stop it either way.
    let _ = child.kill();
    let _ = child.wait();
    server.abort();
    let stderr = || std::fs::read_to_string(&log).unwrap_or_default();
    let body = match got {
        Ok(Some(b)) => b,
        _ => panic!(
            "webgpu: no result from the page in {timeout_s} s; chromium stderr:\n{}",
            stderr()
        ),
    };
    let v: Value = serde_json::from_str(&body)
        .unwrap_or_else(|e| panic!("webgpu page result is not JSON ({e}): {body}"));
    match v["unavailable"].as_str() {
        Some(why) => Err(why.to_owned()),
        None => Ok(v),
    }
}

/// JS for the WebGPU pages:
/// - `probeKernel(group)`: the WGSL compute entry point `swell_probe_cs` appended to a scene's
///   surface module, evaluating what the WebGL2 page's `swell_probe_fs` does at each probe (the
///   displacement and Jacobian at the point; the normal and height above it), its two storage
///   buffers at `@group(group)`;
/// - `openDevice()`: the adapter's description, the device, and the device errors seen so far
///   (uncaptured errors and a lost device), or `{ unavailable }` saying why there is none;
/// - `probeValues(v, n)` splits a probe kernel's read-back (`n` probes, two vec4s each) into the
///   two arrays the tests compare, with `null` for a non-finite value (JSON has no NaN).
pub const PROBE_VALUES_JS: &str = r#"
function probeKernel(group) {
  return `
@group(${group}) @binding(0) var<storage, read> swell_probe_in: array<vec2<f32>>;
@group(${group}) @binding(1) var<storage, read_write> swell_probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn swell_probe_cs(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&swell_probe_in)) {
        return;
    }
    let p = swell_probe_in[i];
    let at = swell_sample(p);
    let above = swell_sample(swell_invert(p));
    swell_probe_out[2u * i] = vec4<f32>(at.displacement, swell_jacobian(above));
    swell_probe_out[2u * i + 1u] = vec4<f32>(swell_normal(above), above.displacement.y);
}
`;
}
async function openDevice() {
  if (!navigator.gpu) return { unavailable: 'navigator.gpu is undefined' };
  const adapter = await navigator.gpu.requestAdapter();
  if (!adapter) return { unavailable: 'requestAdapter() gave no adapter' };
  const info = adapter.info || {};
  const device = await adapter.requestDevice();
  const errors = [];
  device.addEventListener('uncapturederror', (e) => errors.push(String(e.error.message)));
  device.lost.then((l) => errors.push('device lost: ' + l.reason + ' ' + l.message));
  const name = [info.vendor, info.architecture, info.description].filter(Boolean).join(' ');
  return { name, device, errors };
}
function probeValues(v, n) {
  const a = [], b = [];
  for (let i = 0; i < n; i++) {
    for (let j = 0; j < 4; j++) {
      const x = v[8 * i + j], y = v[8 * i + 4 + j];
      a.push(Number.isFinite(x) ? x : null);
      b.push(Number.isFinite(y) ? y : null);
    }
  }
  return { a, b };
}
"#;
