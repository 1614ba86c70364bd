//! One run, start to finish: preflight, setup (bodies, subscribers, query sockets), the load in
//! its window, the optional `/healthz` ceiling, the report.

use std::io::Write as _;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use tokio_util::sync::CancellationToken;

use crate::cli::{Mode, Options, QueryKind};
use crate::driver::{drive, measured};
use crate::report::{Ceiling, Report, SceneSummary};
use crate::server::{self, LoadError, ProcSample, ServerProcess};
use crate::stats::{Recorder, RequestSummary, Window};
use crate::stream::{self, StreamRecorder};
use crate::workload::{HttpWorkload, WsWorkload};
use crate::{http, ws};

/// Runs `o` until its window ends or `stop` fires (then reports what was measured so far).
/// `progress` draws a live line on stderr.
///
/// # Errors
/// A [`LoadError`] when the server cannot be reached, lacks the scene, or refuses setup (admin
/// requests, WebSocket upgrades). Failed requests during the run are not errors: they are counted
/// in the report.
pub async fn run(o: Options, stop: CancellationToken, progress: bool) -> Result<Report, LoadError> {
    let pool = match o.shape {
        crate::cli::Shape::OpenLoop { max_in_flight, .. } => max_in_flight,
        crate::cli::Shape::ClosedLoop { concurrency } => concurrency,
    };
    let client =
        http::client(o.timeout, pool).map_err(|e| LoadError::Setup(format!("HTTP client: {e}")))?;
    let mut scene = server::preflight(&client, &o).await?;
    if o.spawn_bodies > 0 {
        note(
            progress,
            &format!("spawning {} bodies in {}", o.spawn_bodies, o.scene),
        );
        server::spawn_bodies(&client, &o).await?;
        scene.body_ids = server::body_ids(&client, &o).await?;
    }
    if o.subscribers > 0 && (scene.paused || scene.rate == 0.0) {
        return Err(LoadError::Setup(format!(
            "scene {}'s clock is paused: it sends no tick frames (resume it with PUT …/clock)",
            o.scene
        )));
    }
    let subscribers = if o.subscribers > 0 {
        note(
            progress,
            &format!("connecting {} subscribers", o.subscribers),
        );
        stream::connect_all(&o, o.subscribers, &scene.body_ids)
            .await
            .map_err(LoadError::Setup)?
    } else {
        Vec::new()
    };
    let conns = if o.mode == Mode::WsQuery {
        let mut v = Vec::with_capacity(o.connections);
        for _ in 0..o.connections {
            let w = ws::connect(&o.url, &o.scene, o.wire, false, 16 * 1024)
                .await
                .map_err(LoadError::Setup)?;
            v.push(ws::QueryConn::new(w, o.wire, o.timeout));
        }
        Arc::new(v)
    } else {
        Arc::new(Vec::new())
    };

    let window = Window::new(o.warmup, o.duration);
    let rec = Arc::new(Recorder::new(window));
    let srec = Arc::new(StreamRecorder::new(window));
    let own_task = tokio::spawn(watch_own_cpu(window, stop.clone()));
    let proc_task = o.server_pid.map(|pid| {
        let stop = stop.clone();
        tokio::spawn(watch_process(pid, window, stop))
    });
    let live = progress.then(|| {
        tokio::spawn(progress_line(
            "load",
            window,
            rec.clone(),
            Some(srec.clone()),
            stop.clone(),
        ))
    });
    let followers: Vec<_> = subscribers
        .into_iter()
        .map(|s| {
            tokio::spawn(stream::follow(
                s,
                o.wire,
                scene.rate,
                srec.clone(),
                stop.clone(),
            ))
        })
        .collect();

    let grace = o.timeout + Duration::from_secs(1);
    let measured_time = match o.mode {
        Mode::Stream => {
            tokio::select! {
                _ = tokio::time::sleep_until(window.end.into()) => {}
                _ = stop.cancelled() => {}
            }
            let stopped = stop.is_cancelled().then(Instant::now);
            measured(window.start, window.end, stopped)
        }
        Mode::WsQuery => {
            let w = Arc::new(WsWorkload::new(&o));
            let (check, conns) = (o.validate, conns.clone());
            drive(o.shape, rec.clone(), &stop, grace, move |i| {
                let (w, conns) = (w.clone(), conns.clone());
                let kind = w.get(i).kind;
                (kind, async move {
                    let c = &conns[(i as usize) % conns.len()];
                    c.query(w.get(i), check).await
                })
            })
            .await
        }
        _ => {
            http_load(
                &o,
                &client,
                HttpWorkload::new(&o),
                rec.clone(),
                &stop,
                grace,
            )
            .await
        }
    };
    for f in followers {
        let _ = f.await;
    }
    drop(conns);
    if let Some(l) = live {
        l.abort();
        let _ = l.await;
        eprintln!();
    }
    let server = match proc_task {
        Some(t) => t.await.ok().flatten(),
        None => None,
    };
    let tool_cpu_cores = own_task.await.ok().flatten();
    let requests = (o.mode != Mode::Stream).then(|| rec.summary(measured_time));
    let stream = (o.subscribers > 0).then(|| {
        srec.summary(
            o.subscribers,
            measured_time,
            scene.tick_hz * scene.rate.abs(),
        )
    });

    let ceiling = if o.ceiling && !stop.is_cancelled() {
        let healthz = ceiling_run(&o, &client, &stop, grace, progress).await;
        let ratio = requests
            .as_ref()
            .map_or(0.0, |r| r.req_per_s / healthz.req_per_s.max(1e-9));
        Some(Ceiling { healthz, ratio })
    } else {
        None
    };
    Ok(Report {
        tool: "swell-load",
        version: env!("CARGO_PKG_VERSION"),
        scene: SceneSummary {
            tick_hz: scene.tick_hz,
            rate: scene.rate,
            bodies: scene.body_ids.len(),
        },
        measured_s: measured_time.as_secs_f64(),
        interrupted: stop.is_cancelled(),
        requests,
        stream,
        ceiling,
        server,
        tool_cpu_cores,
        options: o,
    })
}

async fn http_load(
    o: &Options,
    client: &reqwest::Client,
    workload: HttpWorkload,
    rec: Arc<Recorder>,
    stop: &CancellationToken,
    grace: Duration,
) -> Duration {
    let w = Arc::new(workload);
    let (client, wire, check) = (client.clone(), o.wire, o.validate);
    drive(o.shape, rec, stop, grace, move |i| {
        let (w, client) = (w.clone(), client.clone());
        let kind = w.get(i).kind;
        (kind, async move {
            http::send(&client, w.get(i), wire, check).await
        })
    })
    .await
}

/// The same shape, warm-up and duration against `GET /healthz`.
async fn ceiling_run(
    o: &Options,
    client: &reqwest::Client,
    stop: &CancellationToken,
    grace: Duration,
    progress: bool,
) -> RequestSummary {
    let window = Window::new(o.warmup, o.duration);
    let rec = Arc::new(Recorder::new(window));
    let live = progress.then(|| {
        tokio::spawn(progress_line(
            "ceiling /healthz",
            window,
            rec.clone(),
            None,
            stop.clone(),
        ))
    });
    let t = http_load(
        o,
        client,
        HttpWorkload::healthz(o),
        rec.clone(),
        stop,
        grace,
    )
    .await;
    if let Some(l) = live {
        l.abort();
        let _ = l.await;
        eprintln!();
    }
    let mut s = rec.summary(t);
    // /healthz answers carry no points.
    s.points_per_s = 0.0;
    for k in &mut s.by_query {
        k.query = QueryKind::Height;
    }
    s
}

/// CPU and memory of `pid` over the window (`None` if `/proc` could not be read).
async fn watch_process(pid: u32, window: Window, stop: CancellationToken) -> Option<ServerProcess> {
    tokio::select! {
        _ = tokio::time::sleep_until(window.start.into()) => {}
        _ = stop.cancelled() => return None,
    }
    let a = ProcSample::read(pid).ok()?;
    tokio::select! {
        _ = tokio::time::sleep_until(window.end.into()) => {}
        _ = stop.cancelled() => {}
    }
    let b = ProcSample::read(pid).ok()?;
    Some(ServerProcess::between(pid, a, b))
}

/// This process's CPU over the window.
async fn watch_own_cpu(window: Window, stop: CancellationToken) -> Option<f64> {
    tokio::select! {
        _ = tokio::time::sleep_until(window.start.into()) => {}
        _ = stop.cancelled() => return None,
    }
    let a = ProcSample::read(std::process::id()).ok();
    tokio::select! {
        _ = tokio::time::sleep_until(window.end.into()) => {}
        _ = stop.cancelled() => {}
    }
    server::own_cpu_cores(a, ProcSample::read(std::process::id()).ok())
}

fn note(progress: bool, what: &str) {
    if progress {
        eprintln!("swell-load: {what}…");
    }
}

/// Redraws one status line on stderr every second until aborted.
async fn progress_line(
    phase: &'static str,
    window: Window,
    rec: Arc<Recorder>,
    stream: Option<Arc<StreamRecorder>>,
    stop: CancellationToken,
) {
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    let mut last_done = 0u64;
    let total = window.end.duration_since(window.begin).as_secs_f64();
    loop {
        tick.tick().await;
        let now = Instant::now();
        let el = now.duration_since(window.begin).as_secs_f64();
        let stage = if stop.is_cancelled() {
            "stopping"
        } else if now < window.start {
            "warm-up"
        } else {
            phase
        };
        let done = rec.live_done.load(Ordering::Relaxed);
        let mut line = format!(
            "[{stage} {el:5.1}/{total:.0} s] {done} requests ({} /s), {} failed",
            done - last_done,
            rec.live_errors.load(Ordering::Relaxed)
        );
        last_done = done;
        if let Some(s) = &stream {
            line.push_str(&format!(
                ", {} frames, {} ticks missed",
                s.live_frames.load(Ordering::Relaxed),
                s.live_gaps.load(Ordering::Relaxed)
            ));
        }
        let mut err = std::io::stderr().lock();
        let _ = write!(err, "\r\x1b[2K{line}");
        let _ = err.flush();
    }
}
