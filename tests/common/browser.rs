//! Headless Chromium for the browser tests (Debian's `chromium`, or `$CHROMIUM`): a page written
//! to a file runs on SwiftShader's WebGL2 and leaves its result as JSON in `<pre id="out">`,
//! which `--dump-dom` prints.

use std::process::Command;

use serde_json::{Value, json};

/// The Chromium binary: `$CHROMIUM`, else `chromium` on the PATH.
pub fn chromium() -> String {
    std::env::var("CHROMIUM").unwrap_or_else(|_| "chromium".into())
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
