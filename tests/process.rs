//! Determinism across processes: the `swell` binary, started as a separate OS process with the
//! same (built-in) scenes, answers bit for bit what an in-process server answers.

mod common;

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

#[tokio::test]
async fn a_second_server_process_answers_the_same_bits() {
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
    let _guard = Killed(child);
    let client = reqwest::Client::builder().no_proxy().build().unwrap();
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
