//! Every mode of `swell-load` against a real server started in this process on 127.0.0.1:0, for
//! a second or two each, asserting real counts: requests answered, no failures, histograms
//! populated, open-loop pacing on its timetable, failures tallied by status and code.
//!
//! The tests take turns (one lock): the pacing figures mean nothing if eight load runs share the
//! machine's cores at once.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use clap::Parser as _;
use swell_load::{LoadError, Options, Report};
use tokio::sync::{Mutex, MutexGuard, oneshot};
use tokio_util::sync::CancellationToken;

const TOKEN: &str = "load-test-token";

static SERIAL: Mutex<()> = Mutex::const_new(());

struct Server {
    addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<std::io::Result<()>>,
    _turn: MutexGuard<'static, ()>,
}

impl Server {
    async fn start() -> Server {
        Self::with_limits(swell::Limits::default()).await
    }

    async fn with_limits(limits: swell::Limits) -> Server {
        let turn = SERIAL.lock().await;
        let config = swell::Config {
            bind: SocketAddr::from(([127, 0, 0, 1], 0)),
            admin_token: Some(TOKEN.into()),
            limits,
            ..Default::default()
        };
        let server = swell::Server::bind(config).await.expect("server starts");
        let addr = server.local_addr();
        let (tx, rx) = oneshot::channel::<()>();
        let task = tokio::spawn(server.run(async move {
            let _ = rx.await;
        }));
        Server {
            addr,
            stop: Some(tx),
            task,
            _turn: turn,
        }
    }

    fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    fn options(&self, argv: &[&str]) -> Options {
        let url = self.url();
        let mut v = vec!["swell-load"];
        v.extend_from_slice(argv);
        v.extend_from_slice(&["--url", &url, "--admin-token", TOKEN]);
        swell_load::Args::try_parse_from(v)
            .expect("arguments parse")
            .into_options()
            .expect("arguments are valid")
    }

    async fn run(&self, argv: &[&str]) -> Report {
        swell_load::run(self.options(argv), CancellationToken::new(), false)
            .await
            .unwrap_or_else(|e| panic!("{argv:?}: {e}"))
    }

    async fn stop(mut self) {
        let _ = self.stop.take().expect("running").send(());
        self.task.await.expect("server task").expect("server ran");
    }
}

fn assert_clean(r: &Report) {
    let q = r.requests.as_ref().expect("requests were sent");
    assert_eq!(q.errors, 0, "failures: {:?}", q.errors_by_kind);
    assert!(q.ok > 0, "nothing answered");
    assert_eq!(q.latency.count, q.ok, "every answer is in the histogram");
    assert!(q.latency.p50_ms > 0.0 && q.latency.p50_ms <= q.latency.p99_ms);
    assert!(q.latency.p99_ms <= q.latency.max_ms);
    assert!(q.bytes_received > 0);
    assert!(!r.has_failures());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn height_closed_loop_answers_and_records_every_request() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "height",
            "--scene",
            "calm",
            "--concurrency",
            "4",
            "--duration",
            "1500ms",
            "--warmup",
            "200ms",
            "--validate",
        ])
        .await;
    assert_clean(&r);
    let q = r.requests.as_ref().unwrap();
    assert!(q.ok >= 100, "{} answered in 1.5 s", q.ok);
    assert!(
        (q.points_per_s - q.req_per_s).abs() < 1e-6,
        "one point each"
    );
    assert!((r.measured_s - 1.5).abs() < 1e-6);
    assert!(!r.interrupted);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn open_loop_pacing_follows_the_timetable() {
    // 200 req/s for 2 s with no warm-up: exactly 400 requests are due (i/200 < 2 s), and a
    // server that keeps up answers all of them (the issue asks for 400 ± 5%).
    let s = Server::start().await;
    let started = Instant::now();
    let r = s
        .run(&[
            "height",
            "--scene",
            "lake",
            "--rate",
            "200",
            "--duration",
            "2s",
            "--warmup",
            "0s",
            "--t",
            "60",
        ])
        .await;
    let took = started.elapsed();
    assert_clean(&r);
    let q = r.requests.as_ref().unwrap();
    assert!((380..=420).contains(&q.ok), "{} answered", q.ok);
    assert!((q.req_per_s - 200.0).abs() <= 10.0, "{} req/s", q.req_per_s);
    // The run does not end early or drag on: the timetable spans 2 s.
    assert!(took >= Duration::from_millis(1990), "{took:?}");
    assert!(took < Duration::from_secs(6), "{took:?}");
    let lag = q.start_lag.as_ref().expect("open loop reports its own lag");
    assert_eq!(lag.count, q.ok);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sample_batches_over_protobuf_count_points() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "sample",
            "--scene",
            "lake",
            "--points",
            "64",
            "--wire",
            "protobuf",
            "--concurrency",
            "2",
            "--duration",
            "1s",
            "--warmup",
            "100ms",
            "--validate",
            "--fields",
            "height,normal",
        ])
        .await;
    assert_clean(&r);
    let q = r.requests.as_ref().unwrap();
    assert!((q.points_per_s - 64.0 * q.req_per_s).abs() < 1e-6);
    assert!(
        q.bytes_sent >= q.ok * 64 * 18,
        "64 protobuf points are >= 18 bytes each"
    );
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn orientation_batches_answer_every_body() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "orientation",
            "--scene",
            "calm",
            "--bodies",
            "3",
            "--concurrency",
            "2",
            "--duration",
            "1s",
            "--warmup",
            "100ms",
            "--validate",
        ])
        .await;
    assert_clean(&r);
    let q = r.requests.as_ref().unwrap();
    assert!((q.points_per_s - 3.0 * q.req_per_s).abs() < 1e-6);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ws_queries_are_matched_by_id_in_both_encodings() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "ws-query",
            "--scene",
            "lake",
            "--connections",
            "2",
            "--concurrency",
            "6",
            "--points",
            "8",
            "--duration",
            "1s",
            "--warmup",
            "100ms",
            "--validate",
        ])
        .await;
    assert_clean(&r);
    assert!(
        (r.requests.as_ref().unwrap().points_per_s - 8.0 * r.requests.as_ref().unwrap().req_per_s)
            .abs()
            < 1e-6
    );
    let r = s
        .run(&[
            "ws-query",
            "--scene",
            "calm",
            "--query",
            "orientation",
            "--bodies",
            "2",
            "--wire",
            "protobuf",
            "--rate",
            "300",
            "--duration",
            "1s",
            "--warmup",
            "0s",
            "--validate",
        ])
        .await;
    assert_clean(&r);
    let q = r.requests.as_ref().unwrap();
    assert!((285..=315).contains(&q.ok), "{} answered of 300 due", q.ok);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stream_subscribers_get_every_tick_with_their_interest_set() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "stream",
            "--scene",
            "calm",
            "--spawn-bodies",
            "4",
            "--subscribers",
            "5",
            "--bodies-per-subscriber",
            "2",
            "--duration",
            "2s",
            "--warmup",
            "300ms",
        ])
        .await;
    assert!(r.requests.is_none());
    assert_eq!(r.scene.bodies, 4);
    let st = r.stream.as_ref().expect("stream summary");
    assert_eq!(st.subscribers, 5);
    assert_eq!(st.tick_hz, 30.0);
    // 5 subscribers × 30 Hz × 2 s = 300 frames, give or take the frames at the window's edges.
    assert!((280..=320).contains(&st.frames), "{} frames", st.frames);
    assert_eq!(st.gaps, 0);
    assert_eq!(st.out_of_order, 0);
    assert_eq!(st.frames_with_unexpected_bodies, 0);
    assert!((st.bodies_per_frame - 2.0).abs() < 1e-9);
    assert_eq!(st.delay.count, st.frames);
    assert!(st.delay.p50_ms < 1000.0, "{:?}", st.delay);
    // Delivery is timed at the socket by the kernel (Linux), the read after it.
    if cfg!(target_os = "linux") {
        assert_eq!(st.frames_timed_at_read, 0);
    }
    assert_eq!(st.read_delay.count, st.frames);
    for (at_socket, read) in [
        (st.delay.p50_ms, st.read_delay.p50_ms),
        (st.delay.p99_ms, st.read_delay.p99_ms),
        (st.delay.max_ms, st.read_delay.max_ms),
    ] {
        assert!(
            read + 0.01 >= at_socket,
            "{:?} {:?}",
            st.delay,
            st.read_delay
        );
    }
    assert!(st.bytes_per_s > 0.0);
    assert!(st.disconnects.is_empty(), "{:?}", st.disconnects);

    // All bodies (no interest set), protobuf frames.
    let r = s
        .run(&[
            "stream",
            "--scene",
            "calm",
            "--subscribers",
            "2",
            "--wire",
            "protobuf",
            "--duration",
            "1s",
            "--warmup",
            "200ms",
        ])
        .await;
    let st = r.stream.as_ref().unwrap();
    assert!(
        (st.bodies_per_frame - 4.0).abs() < 1e-9,
        "{}",
        st.bodies_per_frame
    );
    assert_eq!(st.frames_with_unexpected_bodies, 0);
    assert!(st.frames >= 50, "{}", st.frames);
    let full_bytes = st.bytes_per_s / st.frames_per_s;

    // The same with compact body states: every body still there, in fewer bytes.
    let r = s
        .run(&[
            "stream",
            "--scene",
            "calm",
            "--subscribers",
            "2",
            "--wire",
            "protobuf",
            "--compact",
            "--duration",
            "1s",
            "--warmup",
            "200ms",
        ])
        .await;
    let st = r.stream.as_ref().unwrap();
    assert!((st.bodies_per_frame - 4.0).abs() < 1e-9);
    assert_eq!(st.frames_with_unexpected_bodies, 0);
    let compact_bytes = st.bytes_per_s / st.frames_per_s;
    assert!(
        compact_bytes * 1.8 < full_bytes,
        "compact {compact_bytes} B/frame vs full {full_bytes}"
    );

    // Interest by area: the 4 bodies sit on a 20 m grid around the origin (x, z in -20..0), so
    // a region over x, z in [-25, 5] holds all of them and one far away holds none.
    let r = s
        .run(&[
            "stream",
            "--scene",
            "calm",
            "--subscribers",
            "2",
            "--region",
            "-25,-25,5,5",
            "--duration",
            "1s",
            "--warmup",
            "200ms",
        ])
        .await;
    let st = r.stream.as_ref().unwrap();
    assert!(
        (st.bodies_per_frame - 4.0).abs() < 1e-9,
        "{}",
        st.bodies_per_frame
    );
    let r = s
        .run(&[
            "stream",
            "--scene",
            "calm",
            "--subscribers",
            "2",
            "--region",
            "500,500,600,600",
            "--wire",
            "protobuf",
            "--duration",
            "1s",
            "--warmup",
            "200ms",
        ])
        .await;
    assert_eq!(r.stream.as_ref().unwrap().bodies_per_frame, 0.0);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mixed_runs_every_kind_with_subscribers_beside_it() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "mixed",
            "--scene",
            "lake",
            "--rate",
            "300",
            "--mix",
            "height=6,sample=3,orientation=1",
            "--points",
            "16",
            "--subscribers",
            "2",
            "--duration",
            "1500ms",
            "--warmup",
            "0s",
            "--validate",
        ])
        .await;
    assert_clean(&r);
    let q = r.requests.as_ref().unwrap();
    assert_eq!(q.by_query.len(), 3, "{:?}", q.by_query);
    let total: u64 = q.by_query.iter().map(|k| k.ok).sum();
    assert_eq!(total, q.ok);
    assert!((430..=470).contains(&q.ok), "{} answered of 450 due", q.ok);
    let st = r.stream.as_ref().unwrap();
    assert!(st.frames >= 60, "{}", st.frames);
    assert_eq!(st.gaps, 0);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ceiling_runs_the_same_shape_against_healthz() {
    let s = Server::start().await;
    let r = s
        .run(&[
            "height",
            "--scene",
            "calm",
            "--concurrency",
            "2",
            "--duration",
            "1s",
            "--warmup",
            "100ms",
            "--ceiling",
        ])
        .await;
    assert_clean(&r);
    let c = r.ceiling.as_ref().expect("ceiling");
    assert!(c.healthz.ok > 0);
    assert_eq!(c.healthz.errors, 0);
    let expect = r.requests.as_ref().unwrap().req_per_s / c.healthz.req_per_s;
    assert!((c.ratio - expect).abs() < 1e-9);
    assert!(c.ratio > 0.0 && c.ratio.is_finite());
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn failures_are_tallied_by_status_and_code() {
    let s = Server::with_limits(swell::Limits {
        max_points: 16,
        ..Default::default()
    })
    .await;
    let r = s
        .run(&[
            "sample",
            "--scene",
            "calm",
            "--points",
            "64",
            "--concurrency",
            "2",
            "--duration",
            "500ms",
            "--warmup",
            "0s",
        ])
        .await;
    let q = r.requests.as_ref().unwrap();
    assert_eq!(q.ok, 0);
    assert!(q.errors > 0);
    assert_eq!(q.errors_by_kind.len(), 1, "{:?}", q.errors_by_kind);
    assert_eq!(q.errors_by_kind[0].label, "413 too_many_points");
    assert_eq!(q.errors_by_kind[0].count, q.errors);
    assert!(q.errors_by_kind[0].first.contains("too_many_points"));
    assert!(r.has_failures());
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_c_reports_what_was_measured_so_far() {
    let s = Server::start().await;
    let stop = CancellationToken::new();
    let o = s.options(&[
        "height",
        "--scene",
        "calm",
        "--concurrency",
        "2",
        "--duration",
        "30s",
        "--warmup",
        "0s",
    ]);
    let st = stop.clone();
    tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(700)).await;
        st.cancel();
    });
    let started = Instant::now();
    let r = swell_load::run(o, stop, false).await.expect("run");
    assert!(
        started.elapsed() < Duration::from_secs(5),
        "{:?}",
        started.elapsed()
    );
    assert!(r.interrupted);
    assert!(r.measured_s > 0.5 && r.measured_s < 2.0, "{}", r.measured_s);
    let q = r.requests.as_ref().unwrap();
    assert!(q.ok > 0);
    assert_eq!(q.errors, 0, "{:?}", q.errors_by_kind);
    s.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn setup_failures_stop_the_run_with_the_reason() {
    let s = Server::start().await;
    // An unknown scene lists the ones there are.
    let e = swell_load::run(
        s.options(&["height", "--scene", "atlantis"]),
        CancellationToken::new(),
        false,
    )
    .await
    .expect_err("unknown scene");
    assert!(matches!(e, LoadError::UnknownScene { .. }), "{e}");
    assert!(e.to_string().contains("calm"), "{e}");
    // A refused upgrade says so, with the status.
    let e = swell_load::ws::connect(
        &s.url(),
        "atlantis",
        swell_load::wire::Wire::Json,
        true,
        4096,
    )
    .await
    .expect_err("no such scene");
    assert!(e.contains("upgrade refused: 404"), "{e}");
    // A wrong admin token stops --spawn-bodies.
    let mut o = s.options(&[
        "stream",
        "--scene",
        "calm",
        "--spawn-bodies",
        "2",
        "--duration",
        "1s",
    ]);
    o.admin_token = Some("wrong".into());
    let e = swell_load::run(o, CancellationToken::new(), false)
        .await
        .expect_err("bad token");
    assert!(e.to_string().contains("admin token was refused"), "{e}");
    s.stop().await;

    // Nothing listening: fails fast.
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let url = format!("http://127.0.0.1:{port}");
    let o = swell_load::Args::try_parse_from(["swell-load", "height", "--url", &url])
        .unwrap()
        .into_options()
        .unwrap();
    let started = Instant::now();
    let e = swell_load::run(o, CancellationToken::new(), false)
        .await
        .expect_err("unreachable");
    assert!(matches!(e, LoadError::Unreachable { .. }), "{e}");
    assert!(started.elapsed() < Duration::from_secs(4));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_binary_prints_json_and_exit_codes_say_what_happened() {
    let s = Server::start().await;
    let bin = env!("CARGO_BIN_EXE_swell-load");
    let url = s.url();
    let out = tokio::process::Command::new(bin)
        .args([
            "sample",
            "--url",
            &url,
            "--scene",
            "calm",
            "--points",
            "4",
            "--concurrency",
            "2",
            "--duration",
            "500ms",
            "--warmup",
            "0s",
            "--json",
            "--fail-on-errors",
            "--validate",
        ])
        .output()
        .await
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert!(v["requests"]["ok"].as_u64().unwrap() > 0);
    assert_eq!(v["requests"]["errors"], 0);
    assert_eq!(v["options"]["mode"], "sample");
    assert!(v["requests"]["latency"]["p99_ms"].as_f64().unwrap() > 0.0);
    // Not a terminal: no progress line on stderr.
    assert!(!String::from_utf8_lossy(&out.stderr).contains("requests ("));

    // Human summary.
    let out = tokio::process::Command::new(bin)
        .args([
            "height",
            "--url",
            &url,
            "--scene",
            "calm",
            "--concurrency",
            "1",
            "--duration",
            "300ms",
            "--warmup",
            "0s",
        ])
        .output()
        .await
        .expect("runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(text.contains("req/s") && text.contains("p99"), "{text}");
    s.stop().await;

    // Bad arguments: exit 2, the flag named.
    let out = tokio::process::Command::new(bin)
        .args(["sample", "--points", "0"])
        .output()
        .await
        .expect("runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--points"));
    // Unreachable: exit 1, the reason.
    let out = tokio::process::Command::new(bin)
        .args(["height", "--url", &url])
        .output()
        .await
        .expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot reach"));
}
