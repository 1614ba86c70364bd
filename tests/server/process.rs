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
    let dir = tempfile::tempdir().unwrap();
    let (base, guard) = serve_on(dir.path(), &[], client).await;
    (base, guard, dir)
}

/// Waits until the child at `base` answers `/readyz` 200; fails if it exits or takes a minute.
async fn wait_ready(client: &reqwest::Client, base: &str, guard: &mut Killed) {
    let start = Instant::now();
    loop {
        if let Ok(r) = client.get(format!("{base}/readyz")).send().await
            && r.status() == 200
        {
            return;
        }
        assert!(
            guard.0.try_wait().unwrap().is_none(),
            "the server exited: {:?}",
            guard.0.try_wait()
        );
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the child never became ready"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
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

/// A server whose stdout and stderr cannot be written (a full disk under its log, a closed
/// pipe) keeps serving: log lines and the startup lines are dropped, not a panic (tracing used
/// to report its own write error with `eprintln!`, which panics on the same stderr). A second
/// server on the same data dir is refused, naming it.
#[cfg(target_os = "linux")]
#[tokio::test]
async fn a_full_stderr_does_not_stop_the_server_and_a_data_dir_is_one_process() {
    let port = free_port();
    let dir = tempfile::tempdir().unwrap();
    let full = || Stdio::from(std::fs::File::create("/dev/full").unwrap());
    let child = Command::new(env!("CARGO_BIN_EXE_swell"))
        .args(["serve", "--bind", &format!("127.0.0.1:{port}")])
        .arg("--data-dir")
        .arg(dir.path())
        .args(["--admin-token", "x"])
        .env("RUST_LOG", "debug")
        .stdout(full())
        .stderr(full())
        .spawn()
        .expect("the swell binary starts");
    let mut guard = Killed(child);
    let client = reqwest::Client::new();
    let base = format!("http://127.0.0.1:{port}");
    wait_ready(&client, &base, &mut guard).await;
    // Debug logging writes on every request; each write fails.
    for _ in 0..20 {
        let r = client
            .get(format!("{base}/v1/scenes/calm/height?x=1&z=2"))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
    }
    assert!(guard.0.try_wait().unwrap().is_none(), "still running");
    let second = Command::new(env!("CARGO_BIN_EXE_swell"))
        .args(["serve", "--bind", "127.0.0.1:0", "--admin-token", "x"])
        .arg("--data-dir")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!second.status.success());
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(err.contains("in use by another swell process"), "{err}");
}

/// `swell serve` on `dir` with extra arguments, once ready; killed (SIGKILL) on drop.
async fn serve_on(
    dir: &std::path::Path,
    extra: &[&str],
    client: &reqwest::Client,
) -> (String, Killed) {
    let port = free_port();
    let child = Command::new(env!("CARGO_BIN_EXE_swell"))
        .args([
            "serve",
            "--bind",
            &format!("127.0.0.1:{port}"),
            "--admin-token",
            "x",
        ])
        .arg("--data-dir")
        .arg(dir)
        .args(extra)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the swell binary starts");
    let mut guard = Killed(child);
    let base = format!("http://127.0.0.1:{port}");
    wait_ready(client, &base, &mut guard).await;
    (base, guard)
}

/// Records read back at start count toward `--snapshot-records`: a server killed before it
/// compacted, restarted with the log over the limit, compacts within a few seconds (it used to
/// count only the records it wrote itself, so a crash loop grew the replay without end).
#[tokio::test]
async fn records_replayed_at_start_count_toward_the_snapshot_limit() {
    let client = reqwest::Client::new();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("journal").join("journal.log");
    let (base, guard) = serve_on(
        dir.path(),
        &[
            "--snapshot-records",
            "100000",
            "--snapshot-interval",
            "3600",
        ],
        &client,
    )
    .await;
    for i in 0..12 {
        let r = client
            .put(format!("{base}/v1/scenes/s{i}"))
            .bearer_auth("x")
            .json(&common::small_spec())
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 201);
    }
    drop(guard); // kill -9: no final snapshot
    let before = std::fs::metadata(&log).unwrap().len();
    let (_base, _guard) = serve_on(
        dir.path(),
        &["--snapshot-records", "5", "--snapshot-interval", "3600"],
        &client,
    )
    .await;
    let start = Instant::now();
    while std::fs::metadata(&log).unwrap().len() >= before {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "the replayed log was never compacted ({before} bytes)"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// SIGTERM: `/readyz` answers 503 for `--drain-delay` while the server still serves, then the
/// server stops accepting and exits within `--shutdown-timeout` of that even though a client
/// holds a request head half sent (it used to wait out `head_timeout_ms`, 10 s).
#[cfg(unix)]
#[tokio::test]
async fn sigterm_turns_readyz_503_then_exits_within_the_deadline() {
    use tokio::io::AsyncWriteExt as _;
    let client = reqwest::Client::new();
    let dir = tempfile::tempdir().unwrap();
    let (base, mut guard) = serve_on(
        dir.path(),
        &["--drain-delay", "1", "--shutdown-timeout", "1"],
        &client,
    )
    .await;
    let addr = base.trim_start_matches("http://").to_owned();
    let mut slow = tokio::net::TcpStream::connect(&addr).await.unwrap();
    slow.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(100)).await;
    let pid = i32::try_from(guard.0.id()).unwrap();
    // SAFETY: signalling our own child process.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let signalled = Instant::now();
    let mut saw_503 = false;
    while signalled.elapsed() < Duration::from_millis(800) {
        if let Ok(r) = client.get(format!("{base}/readyz")).send().await {
            saw_503 |= r.status() == 503;
            let h = client.get(format!("{base}/healthz")).send().await.unwrap();
            assert_eq!(h.status(), 200, "still serving while draining");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert!(saw_503, "/readyz never answered 503 during the drain delay");
    let status = loop {
        if let Some(s) = guard.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            signalled.elapsed() < Duration::from_secs(5),
            "still running 5 s after SIGTERM (drain 1 s + deadline 1 s)"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    assert!(status.success(), "{status:?}");
    drop(slow);
}

/// The `SWELL_` variables the token rule reads, removed from a child so the test's own
/// environment cannot change what it is told.
const SWELL_VARS: &[&str] = &[
    "SWELL_BIND",
    "SWELL_PROBE_BIND",
    "SWELL_ADMIN_TOKEN",
    "SWELL_ADMIN_TOKENS",
    "SWELL_GAME_TOKENS",
    "SWELL_READER_TOKENS",
    "SWELL_TOKENS_FILE",
    "SWELL_DATA_DIR",
    "SWELL_CONFIG",
];

/// `swell serve` with `args` and `env` on a fresh data dir: `Some(status)` if it exited within
/// 20 s, `None` if it started serving (it printed its listening line; then it is killed); and
/// its stdout and stderr.
fn serve_briefly(
    args: &[&str],
    env: &[(&str, &str)],
) -> (Option<std::process::ExitStatus>, String, String) {
    use std::io::{BufRead as _, Read as _};
    let dir = tempfile::tempdir().unwrap();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_swell"));
    cmd.arg("serve")
        .args(args)
        .arg("--data-dir")
        .arg(dir.path())
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for v in SWELL_VARS {
        cmd.env_remove(v);
    }
    cmd.envs(env.iter().copied());
    let mut guard = Killed(cmd.spawn().expect("the swell binary starts"));
    let stdout = guard.0.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let start = Instant::now();
    let mut out = String::new();
    let status = loop {
        match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(line) => {
                out.push_str(&line);
                out.push('\n');
                if line.starts_with("swell listening on") {
                    break None;
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if let Some(s) = guard.0.try_wait().unwrap() {
                    break Some(s);
                }
                assert!(
                    start.elapsed() < Duration::from_secs(20),
                    "{args:?}: neither serving nor exited after 20 s"
                );
            }
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                break Some(guard.0.wait().unwrap());
            }
        }
    };
    let _ = guard.0.kill();
    let _ = guard.0.wait();
    let _ = reader.join();
    let mut err = String::new();
    guard
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (status, out, err)
}

/// Tokens given on the command line or in the environment shorter than 16 bytes, the tokens
/// file's rule, used to be accepted on any address. A server that listens beyond loopback
/// (`--bind` or `--probe-bind`) now refuses them (exit 1, naming the option, the rule and the
/// address, never the token); one that listens on loopback only takes them with a warning
/// on stderr, as every test and script does with `--admin-token tok`.
#[test]
fn a_short_cli_or_env_token_is_refused_beyond_loopback_and_warned_about_on_it() {
    const LONG: &str = "admin-token-0123456789";
    const SHORT: &str = "zq9";
    // (args, env, the option the message names, the bind option and address it names).
    type Case<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a str, &'a str);
    let refused: &[Case] = &[
        (
            &["--bind", "0.0.0.0:0", "--admin-token", SHORT],
            &[],
            "--admin-token",
            "--bind 0.0.0.0:0",
        ),
        (
            &["--bind", "127.0.0.1:0", "--probe-bind", "0.0.0.0:0"],
            &[("SWELL_ADMIN_TOKEN", SHORT)],
            "--admin-token",
            "--probe-bind 0.0.0.0:0",
        ),
        (
            &["--bind", "[::]:0", "--admin-token", LONG],
            &[("SWELL_GAME_TOKENS", "game-token-0123456789, zq9")],
            "--game-tokens",
            "--bind [::]:0",
        ),
        (
            &["--admin-token", LONG],
            &[("SWELL_BIND", "0.0.0.0:0"), ("SWELL_READER_TOKENS", SHORT)],
            "--reader-tokens",
            "--bind 0.0.0.0:0",
        ),
        (
            &[
                "--bind",
                "0.0.0.0:0",
                "--admin-tokens",
                "admin-token-0123456789,zq9",
            ],
            &[],
            "--admin-tokens",
            "--bind 0.0.0.0:0",
        ),
    ];
    for (args, env, option, bind) in refused {
        let (status, _, err) = serve_briefly(args, env);
        assert_eq!(
            status.and_then(|s| s.code()),
            Some(1),
            "{args:?} {env:?}: {status:?}\n{err}"
        );
        for want in [*option, "16 bytes", *bind] {
            assert!(
                err.contains(want),
                "{args:?} {env:?}: no {want:?} in\n{err}"
            );
        }
        assert!(!err.contains(SHORT), "the token itself is printed:\n{err}");
    }

    // Loopback only: served, with one warning line per short token.
    let warned: &[Case] = &[
        (
            &["--bind", "127.0.0.1:0", "--admin-token", SHORT],
            &[],
            "--admin-token",
            "",
        ),
        (
            &[
                "--bind",
                "127.0.0.1:0",
                "--probe-bind",
                "127.0.0.2:0",
                "--admin-token",
                LONG,
            ],
            &[("SWELL_GAME_TOKENS", SHORT)],
            "--game-tokens",
            "",
        ),
    ];
    for (args, env, option, _) in warned {
        let (status, out, err) = serve_briefly(args, env);
        assert_eq!(status, None, "{args:?} {env:?}: exited\n{out}\n{err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.contains("16 bytes")).collect();
        assert_eq!(lines.len(), 1, "{args:?} {env:?}: {err}");
        assert!(
            lines[0].contains("warning")
                && lines[0].contains(option)
                && lines[0].contains("loopback"),
            "{args:?} {env:?}: {}",
            lines[0]
        );
        assert!(!err.contains(SHORT), "the token itself is printed:\n{err}");
    }

    // Long tokens beyond loopback: served, no warning.
    let (status, out, err) = serve_briefly(&["--bind", "0.0.0.0:0", "--admin-token", LONG], &[]);
    assert_eq!(status, None, "{out}\n{err}");
    assert!(!err.contains("16 bytes"), "{err}");
}
