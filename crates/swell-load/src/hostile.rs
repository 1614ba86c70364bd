//! `swell-load hostile`: a bounded battery of slow and hostile clients against a server on
//! loopback, beside a well-behaved client and a health prober, to measure what the hostile ones
//! cost everyone else.
//!
//! Every attacker binds its own loopback source address (127.0.2.x, 127.0.3.x, …), so the
//! server sees distinct peers and its per-peer limits apply as they would on the internet; the
//! well-behaved client is 127.0.0.1. The server under test must not exempt loopback from its
//! per-peer limits (`[limits] exempt_peers = []`, `trusted_proxies = []`): `.ci/hostile` writes
//! that config.
//!
//! Phases: a baseline of the good client alone, then the attack for `--duration`, then a
//! settle time with the attackers gone. The attack:
//! - `--slow-bodies` sockets that send a POST's headers and then one body byte a second
//!   (reconnecting when the server gives up on them), over 8 addresses;
//! - `--non-readers` HTTP clients that post a large sample and never read the answer, and as many
//!   WebSocket clients that subscribe and send queries but never read, each from its own address;
//! - a flood: `--flood-connections` connections from one address asking for heights at
//!   `--flood-rate` in all (four times the default per-address limit);
//! - `--idle` connections from one address that send nothing.
//!
//! Only loopback targets are accepted, and every count has a ceiling.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use futures_util::SinkExt as _;
use serde::Serialize;
use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
use tokio::net::{TcpSocket, TcpStream};
use tokio_util::sync::CancellationToken;

/// How long the good client runs alone before the attack: 250 requests at the default rate,
/// so that its p99 is not one outlier.
const BASELINE: Duration = Duration::from_secs(5);

/// How long after the attack the server's memory is read again.
const SETTLE: Duration = Duration::from_secs(12);

/// Ceilings on every count, so the tool cannot be turned into a real flood.
const MAX_SOCKETS: usize = 12_000;

/// `swell-load hostile` arguments.
#[derive(Debug, Clone, clap::Parser)]
#[command(name = "swell-load hostile")]
pub struct HostileArgs {
    /// The server, `http://127.0.0.1:PORT` (loopback only).
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub url: String,
    /// The scene the clients query.
    #[arg(long, default_value = "calm")]
    pub scene: String,
    /// The server's pid, to read its resident memory (`/proc/PID/statm`).
    #[arg(long)]
    pub server_pid: Option<u32>,
    /// How long the attack lasts, s.
    #[arg(long, default_value_t = 20.0)]
    pub duration: f64,
    /// Sockets trickling a request body.
    #[arg(long, default_value_t = 1000)]
    pub slow_bodies: usize,
    /// HTTP clients (and as many WebSocket clients) that never read their answers.
    #[arg(long, default_value_t = 100)]
    pub non_readers: usize,
    /// Points in each non-reader's sample request.
    #[arg(long, default_value_t = 20_000)]
    pub non_reader_points: usize,
    /// Connections of the flood, all from one address.
    #[arg(long, default_value_t = 8)]
    pub flood_connections: usize,
    /// Requests a second the flood sends, over all its connections: four times the server's
    /// default per-address rate. (An unpaced flood on the same two cores as the server mostly
    /// measures the battery's own CPU use, not the server's defence.)
    #[arg(long, default_value_t = 2000.0)]
    pub flood_rate: f64,
    /// Idle connections from one address.
    #[arg(long, default_value_t = 10_000)]
    pub idle: usize,
    /// Requests a second of the well-behaved client.
    #[arg(long, default_value_t = 50.0)]
    pub good_rate: f64,
    /// The attackers' CPU priority (Linux): `normal`, `low` (niceness 19) or `idle`
    /// (`SCHED_IDLE`: they run only on CPU time nothing else wants, and yield the moment the
    /// server or the good client wakes). The well-behaved client, the probes and the memory
    /// watcher keep the tool's own priority. With the battery on the server's cores, every cycle
    /// an attacker spends is one the server and the good client cannot have, and the kernel
    /// lets a running attacker finish its time slice (~1–3 ms) before a woken server thread
    /// runs: at `normal` the good client's tail measures that. At `idle` the attackers still
    /// send at their full rates (the report gives them) but take no time the server wants, as
    /// attackers on other machines would.
    #[arg(long, value_enum, default_value_t = AttackerPriority::Normal)]
    pub attacker_priority: AttackerPriority,
    /// Fail (exit 1) unless: probes p99 < 50 ms, every good request answered 2xx, good p99 ≤
    /// `--p99-factor` × its baseline (or ≤ `--p99-floor-ms`), no good answer slower than
    /// `--max-ms` (when set), and resident memory within `--rss-budget-mb` of the start during
    /// the attack and within `--rss-settle-mb` after.
    #[arg(long)]
    pub assert: bool,
    /// See `--assert`.
    #[arg(long, default_value_t = 3.0)]
    pub p99_factor: f64,
    /// A p99 this low passes whatever the baseline (timer and scheduler noise on loopback), ms.
    #[arg(long, default_value_t = 5.0)]
    pub p99_floor_ms: f64,
    /// The slowest good answer allowed during the attack, ms (0: not checked). A stall of the
    /// whole server (every reactor thread busy at once) shows here before it moves the p99.
    #[arg(long, default_value_t = 0.0)]
    pub max_ms: f64,
    /// With `--assert`: fail unless the server's `/metrics` shows its slow lane at work after
    /// the attack (demotions and connections served there).
    #[arg(long)]
    pub expect_slow_lane: bool,
    /// See `--assert`, MiB.
    #[arg(long, default_value_t = 320.0)]
    pub rss_budget_mb: f64,
    /// See `--assert`, MiB.
    #[arg(long, default_value_t = 64.0)]
    pub rss_settle_mb: f64,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Latencies of one client, ms.
#[derive(Debug, Default, Clone, Serialize)]
pub struct Latency {
    /// Requests sent.
    pub sent: u64,
    /// Answered 2xx.
    pub ok: u64,
    /// Any other outcome (status or transport error).
    pub failed: u64,
    /// Median, ms.
    pub p50_ms: f64,
    /// 99th percentile, ms.
    pub p99_ms: f64,
    /// Slowest, ms.
    pub max_ms: f64,
}

impl Latency {
    fn from(samples: &mut [f64], ok: u64, failed: u64) -> Latency {
        samples.sort_by(f64::total_cmp);
        let q = |p: f64| {
            if samples.is_empty() {
                return 0.0;
            }
            let i = ((samples.len() as f64 - 1.0) * p).round() as usize;
            samples[i.min(samples.len() - 1)]
        };
        Latency {
            sent: ok + failed,
            ok,
            failed,
            p50_ms: q(0.5),
            p99_ms: q(0.99),
            max_ms: samples.last().copied().unwrap_or(0.0),
        }
    }
}

/// What the battery measured.
#[derive(Debug, Default, Clone, Serialize)]
pub struct HostileReport {
    /// The good client alone.
    pub baseline: Latency,
    /// The good client during the attack.
    pub during: Latency,
    /// `/healthz` and `/readyz` during the attack.
    pub probes: Latency,
    /// Slow-body sockets opened (reconnections included).
    pub slow_body_sockets: u64,
    /// Slow-body sockets the server answered 408.
    pub slow_body_408: u64,
    /// Non-reading clients (HTTP, WebSocket) seen disconnected during the attack (a lower bound:
    /// an HTTP non-reader answered 503 over the byte budget keeps its connection).
    pub non_readers_cut: u64,
    /// Flood requests answered 429.
    pub flood_429: u64,
    /// Flood requests answered 2xx.
    pub flood_ok: u64,
    /// Idle connections refused at once (429 and closed).
    pub idle_refused: u64,
    /// Idle connections still open at the end of the attack.
    pub idle_held: u64,
    /// The attack's length, s (for the rates below).
    pub attack_s: f64,
    /// The attackers' CPU priority (`--attacker-priority`).
    pub attacker_priority: AttackerPriority,
    /// Server resident memory at the start, MiB.
    pub rss_start_mb: f64,
    /// Highest resident memory seen during the attack, MiB.
    pub rss_peak_mb: f64,
    /// Resident memory after the settle time, MiB.
    pub rss_after_mb: f64,
    /// The server's slow lane after the attack, from its `/metrics`: addresses demoted
    /// (`swell_peers_demoted_total`, every reason) and connections served there
    /// (`swell_http_slow_lane_connections_total`). `None` where `/metrics` did not say (a
    /// server without the lane, or whose `/metrics` needs a token).
    pub slow_lane: Option<SlowLaneCounts>,
    /// Failed checks (with `--assert`).
    pub failures: Vec<String>,
}

/// What the server's `/metrics` says of its slow lane.
#[derive(Debug, Default, Clone, Copy, Serialize)]
pub struct SlowLaneCounts {
    /// Demotions (an address demoted again after its demotion ended counts again).
    pub demoted: u64,
    /// Connections (and refusals) served on the slow lane.
    pub connections: u64,
}

/// The slow-lane counters in a Prometheus text page; `None` when neither is there.
fn slow_lane_counts(page: &str) -> Option<SlowLaneCounts> {
    let mut seen = false;
    let mut c = SlowLaneCounts::default();
    for line in page.lines() {
        let Some((name, value)) = line.rsplit_once(' ') else {
            continue;
        };
        let Ok(v) = value.trim().parse::<f64>() else {
            continue;
        };
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let v = v as u64;
        let metric = name.split('{').next().unwrap_or(name);
        match metric {
            "swell_peers_demoted_total" => c.demoted += v,
            "swell_http_slow_lane_connections_total" => c.connections += v,
            _ => continue,
        }
        seen = true;
    }
    seen.then_some(c)
}

fn rss_mb(pid: Option<u32>) -> f64 {
    let Some(pid) = pid else { return 0.0 };
    std::fs::read_to_string(format!("/proc/{pid}/statm"))
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<f64>().ok())
        .map_or(0.0, |pages| pages * 4096.0 / 1048576.0)
}

/// Raises this process's open-file limit to its hard limit (thousands of sockets).
fn raise_nofile() {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit/setrlimit read and write the plain struct passed by pointer.
    unsafe {
        if libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) == 0 && lim.rlim_cur < lim.rlim_max {
            lim.rlim_cur = lim.rlim_max;
            let _ = libc::setrlimit(libc::RLIMIT_NOFILE, &lim);
        }
    }
}

async fn connect_from(src: Ipv4Addr, to: SocketAddr) -> std::io::Result<TcpStream> {
    let s = TcpSocket::new_v4()?;
    s.bind(SocketAddr::new(IpAddr::V4(src), 0))?;
    s.connect(to).await
}

/// Runs the battery.
///
/// # Errors
/// A target that is not loopback, counts over the ceiling, or a server that does not answer.
pub async fn run(args: &HostileArgs) -> anyhow::Result<HostileReport> {
    let addr: SocketAddr = args
        .url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .parse()
        .map_err(|_| anyhow::anyhow!("--url must be http://127.x.x.x:PORT"))?;
    anyhow::ensure!(
        addr.ip().is_loopback(),
        "--url must be a loopback address: the battery never targets another host"
    );
    let total = args.slow_bodies + 2 * args.non_readers + args.flood_connections + args.idle;
    anyhow::ensure!(
        total <= MAX_SOCKETS,
        "{total} sockets asked for; at most {MAX_SOCKETS}"
    );
    raise_nofile();
    let base = format!("http://{addr}");
    let good = reqwest::Client::builder()
        .no_proxy()
        .local_address(IpAddr::V4(Ipv4Addr::LOCALHOST))
        .timeout(Duration::from_secs(10))
        .build()?;
    let height = format!("{base}/v1/scenes/{}/height?x=1.5&z=-2.25", args.scene);
    anyhow::ensure!(
        good.get(&height).send().await?.status().is_success(),
        "the server does not answer {height}"
    );
    let mut report = HostileReport {
        rss_start_mb: rss_mb(args.server_pid),
        ..Default::default()
    };

    eprintln!(
        "hostile: baseline, {} s of the good client alone",
        BASELINE.as_secs()
    );
    report.baseline = good_client_apart(&height, args.good_rate, BASELINE).await;

    eprintln!(
        "hostile: attack for {} s ({} slow bodies, {} non-readers x2, flood x{}, {} idle)",
        args.duration, args.slow_bodies, args.non_readers, args.flood_connections, args.idle
    );
    let stop = CancellationToken::new();
    let counters = Arc::new(Counters::default());
    // The attackers run on a runtime of their own, whose threads take `--attacker-priority`.
    let attackers = attacker_runtime(args.attacker_priority).await?;
    let mut tasks = Spawner {
        set: tokio::task::JoinSet::new(),
        on: attackers.handle().clone(),
    };
    for i in 0..args.slow_bodies {
        let src = Ipv4Addr::new(127, 0, 2, 1 + (i % 8) as u8);
        tasks.spawn(slow_body(
            src,
            addr,
            args.scene.clone(),
            stop.clone(),
            counters.clone(),
        ));
    }
    let big = Arc::new(sample_body(args.non_reader_points));
    for i in 0..args.non_readers {
        let src = Ipv4Addr::new(127, 0, 3 + (i / 250) as u8, 1 + (i % 250) as u8);
        tasks.spawn(http_non_reader(
            src,
            addr,
            args.scene.clone(),
            big.clone(),
            stop.clone(),
            counters.clone(),
        ));
        let src = Ipv4Addr::new(127, 0, 6 + (i / 250) as u8, 1 + (i % 250) as u8);
        tasks.spawn(ws_non_reader(
            src,
            addr,
            args.scene.clone(),
            stop.clone(),
            counters.clone(),
        ));
    }
    let per_conn = args.flood_rate.clamp(1.0, 100_000.0) / args.flood_connections.max(1) as f64;
    for _ in 0..args.flood_connections {
        tasks.spawn(flood(
            height.clone(),
            per_conn,
            stop.clone(),
            counters.clone(),
        ));
    }
    {
        let (stop, counters, n) = (stop.clone(), counters.clone(), args.idle);
        tasks.spawn(idle(addr, n, stop, counters));
    }
    // Let the attackers connect, then measure.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let pid = args.server_pid;
    let peak = Arc::new(AtomicU64::new(0));
    let watcher = {
        let (peak, stop) = (peak.clone(), stop.clone());
        tokio::spawn(async move {
            while !stop.is_cancelled() {
                let mb = (rss_mb(pid) * 1024.0) as u64;
                peak.fetch_max(mb, Ordering::Relaxed);
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        })
    };
    let attack = Duration::from_secs_f64(args.duration.clamp(1.0, 600.0));
    report.attack_s = attack.as_secs_f64();
    report.attacker_priority = args.attacker_priority;
    let probes = tokio::spawn(probe(base.clone(), attack));
    report.during = good_client_apart(&height, args.good_rate, attack).await;
    report.probes = probes.await.unwrap_or_default();
    stop.cancel();
    let _ = watcher.await;
    report.rss_peak_mb = peak.load(Ordering::Relaxed) as f64 / 1024.0;
    report.idle_held = counters.idle_held.load(Ordering::Relaxed);
    // Give every attacker a moment to hang up, then settle.
    let _ = tokio::time::timeout(Duration::from_secs(5), async {
        while tasks.set.join_next().await.is_some() {}
    })
    .await;
    tasks.set.abort_all();
    attackers.shutdown_background();
    // Long enough for the server's idle blocking threads to retire (tokio keeps them 10 s) and
    // for two of its 5 s heap-trim beats.
    eprintln!("hostile: attackers gone; settling {} s", SETTLE.as_secs());
    tokio::time::sleep(SETTLE).await;
    report.rss_after_mb = rss_mb(args.server_pid);
    report.slow_lane = match reqwest::Client::new()
        .get(format!("{base}/metrics"))
        .timeout(Duration::from_secs(5))
        .send()
        .await
    {
        Ok(r) if r.status().is_success() => r.text().await.ok().and_then(|p| slow_lane_counts(&p)),
        _ => None,
    };
    let c = &counters;
    report.slow_body_sockets = c.slow_sockets.load(Ordering::Relaxed);
    report.slow_body_408 = c.slow_408.load(Ordering::Relaxed);
    report.non_readers_cut = c.non_readers_cut.load(Ordering::Relaxed);
    report.flood_429 = c.flood_429.load(Ordering::Relaxed);
    report.flood_ok = c.flood_ok.load(Ordering::Relaxed);
    report.idle_refused = c.idle_refused.load(Ordering::Relaxed);

    if args.assert {
        let r = &mut report;
        let mut fail = |m: String| r.failures.push(m);
        if r.probes.p99_ms >= 50.0 || r.probes.failed > 0 {
            fail(format!(
                "probes: p99 {:.1} ms, {} failed (want < 50 ms, none)",
                r.probes.p99_ms, r.probes.failed
            ));
        }
        if r.during.failed > 0 || r.during.ok == 0 {
            fail(format!(
                "good client: {} of {} requests failed",
                r.during.failed, r.during.sent
            ));
        }
        let bound = (args.p99_factor * r.baseline.p99_ms).max(args.p99_floor_ms);
        if r.during.p99_ms > bound {
            fail(format!(
                "good client p99 {:.2} ms > {bound:.2} ms ({}x its baseline {:.2} ms, floor {} ms)",
                r.during.p99_ms, args.p99_factor, r.baseline.p99_ms, args.p99_floor_ms
            ));
        }
        if args.max_ms > 0.0 && r.during.max_ms > args.max_ms {
            fail(format!(
                "the good client's slowest answer took {:.1} ms (--max-ms {})",
                r.during.max_ms, args.max_ms
            ));
        }
        if args.expect_slow_lane {
            match r.slow_lane {
                Some(c) if c.demoted > 0 && c.connections > 0 => {}
                Some(c) => fail(format!(
                    "the slow lane did not work: {} demotions, {} connections served there",
                    c.demoted, c.connections
                )),
                None => fail("the server's /metrics says nothing of a slow lane".to_owned()),
            }
        }
        if pid.is_some() {
            if r.rss_peak_mb > r.rss_start_mb + args.rss_budget_mb {
                fail(format!(
                    "RSS peaked at {:.0} MiB from {:.0} MiB (budget +{} MiB)",
                    r.rss_peak_mb, r.rss_start_mb, args.rss_budget_mb
                ));
            }
            if r.rss_after_mb > r.rss_start_mb + args.rss_settle_mb {
                fail(format!(
                    "RSS {:.0} MiB after the attack, from {:.0} MiB (want within +{} MiB)",
                    r.rss_after_mb, r.rss_start_mb, args.rss_settle_mb
                ));
            }
        }
    }
    Ok(report)
}

/// A [`tokio::task::JoinSet`] whose tasks run on the attackers' runtime.
struct Spawner {
    set: tokio::task::JoinSet<()>,
    on: tokio::runtime::Handle,
}

impl Spawner {
    fn spawn(&mut self, task: impl Future<Output = ()> + Send + 'static) {
        self.set.spawn_on(task, &self.on);
    }
}

/// The attackers' CPU priority (`--attacker-priority`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AttackerPriority {
    /// The tool's own priority.
    #[default]
    Normal,
    /// Niceness 19.
    Low,
    /// `SCHED_IDLE` (and niceness 19).
    Idle,
}

impl std::fmt::Display for AttackerPriority {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            AttackerPriority::Normal => "normal",
            AttackerPriority::Low => "low (nice 19)",
            AttackerPriority::Idle => "idle (SCHED_IDLE)",
        })
    }
}

/// The attackers' runtime: two worker threads (the machines these runs are made on have two
/// cores) at `priority`.
async fn attacker_runtime(priority: AttackerPriority) -> anyhow::Result<tokio::runtime::Runtime> {
    let failed = Arc::new(std::sync::Mutex::new(None));
    let seen = Arc::clone(&failed);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("swell-load-attacker")
        .enable_all()
        .on_thread_start(move || {
            if let Err(e) = set_thread_priority(priority)
                && let Ok(mut f) = seen.lock()
            {
                *f = Some(e);
            }
        })
        .build()
        .map_err(|e| anyhow::anyhow!("cannot start the attackers' runtime: {e}"))?;
    // The workers start with the runtime: a refusal shows once a task has run on it.
    let _ = rt.spawn(async {}).await;
    if let Some(e) = failed.lock().ok().and_then(|mut f| f.take()) {
        anyhow::bail!("--attacker-priority {priority}: {e}");
    }
    Ok(rt)
}

/// Sets the calling thread's priority (Linux: `setpriority` and `sched_setscheduler` on a
/// thread id apply to that thread only; lowering a priority needs no privilege).
fn set_thread_priority(priority: AttackerPriority) -> std::io::Result<()> {
    if priority == AttackerPriority::Normal {
        return Ok(());
    }
    #[cfg(target_os = "linux")]
    // SAFETY: gettid has no preconditions; setpriority and sched_setscheduler take plain
    // integers and a pointer to a local.
    unsafe {
        let tid = libc::gettid();
        #[allow(clippy::cast_sign_loss)]
        if libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, 19) != 0 {
            return Err(std::io::Error::last_os_error());
        }
        if priority == AttackerPriority::Idle {
            let p = libc::sched_param { sched_priority: 0 };
            if libc::sched_setscheduler(tid, libc::SCHED_IDLE, &raw const p) != 0 {
                return Err(std::io::Error::last_os_error());
            }
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    Err(std::io::Error::new(
        std::io::ErrorKind::Unsupported,
        "attacker priorities are set on Linux only",
    ))
}

#[derive(Debug, Default)]
struct Counters {
    slow_sockets: AtomicU64,
    slow_408: AtomicU64,
    non_readers_cut: AtomicU64,
    flood_429: AtomicU64,
    flood_ok: AtomicU64,
    idle_refused: AtomicU64,
    idle_held: AtomicU64,
}

/// [`good_client`] on a thread and runtime of its own, as a real client is: on the battery's
/// runtime every answer it gets waits behind thousands of attacker tasks before its timer is
/// read (measured: half its p99 under attack was that wait, not the server).
async fn good_client_apart(url: &str, rate: f64, dur: Duration) -> Latency {
    let url = url.to_owned();
    let (tx, rx) = tokio::sync::oneshot::channel();
    std::thread::spawn(move || {
        let latency = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .ok()
            .and_then(|rt| {
                rt.block_on(async {
                    let client = reqwest::Client::builder()
                        .no_proxy()
                        .local_address(IpAddr::V4(Ipv4Addr::LOCALHOST))
                        .timeout(Duration::from_secs(10))
                        .build()
                        .ok()?;
                    Some(good_client(&client, &url, rate, dur).await)
                })
            })
            .unwrap_or_default();
        let _ = tx.send(latency);
    });
    rx.await.unwrap_or_default()
}

/// The good client: `rate` sequential-ish requests a second for `dur`.
async fn good_client(client: &reqwest::Client, url: &str, rate: f64, dur: Duration) -> Latency {
    let start = Instant::now();
    let every = Duration::from_secs_f64(1.0 / rate.clamp(1.0, 1000.0));
    let (mut ms, mut ok, mut failed) = (Vec::new(), 0, 0);
    let mut next = tokio::time::Instant::now();
    while start.elapsed() < dur {
        tokio::time::sleep_until(next).await;
        next += every;
        let t0 = Instant::now();
        match client.get(url).send().await {
            Ok(r) if r.status().is_success() => {
                let _ = r.bytes().await;
                ok += 1;
            }
            _ => failed += 1,
        }
        ms.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    Latency::from(&mut ms, ok, failed)
}

/// `/healthz` and `/readyz` alternately every 20 ms for `dur`.
async fn probe(base: String, dur: Duration) -> Latency {
    let Ok(client) = reqwest::Client::builder()
        .no_proxy()
        .timeout(Duration::from_secs(5))
        .build()
    else {
        return Latency::default();
    };
    let start = Instant::now();
    let (mut ms, mut ok, mut failed) = (Vec::new(), 0, 0);
    let mut i = 0u64;
    while start.elapsed() < dur {
        let path = if i.is_multiple_of(2) {
            "/healthz"
        } else {
            "/readyz"
        };
        i += 1;
        let t0 = Instant::now();
        match client.get(format!("{base}{path}")).send().await {
            Ok(r) if r.status().is_success() => ok += 1,
            _ => failed += 1,
        }
        ms.push(t0.elapsed().as_secs_f64() * 1e3);
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    Latency::from(&mut ms, ok, failed)
}

async fn slow_body(
    src: Ipv4Addr,
    to: SocketAddr,
    scene: String,
    stop: CancellationToken,
    c: Arc<Counters>,
) {
    while !stop.is_cancelled() {
        let Ok(mut s) = connect_from(src, to).await else {
            tokio::time::sleep(Duration::from_millis(200)).await;
            continue;
        };
        c.slow_sockets.fetch_add(1, Ordering::Relaxed);
        let head = format!(
            "POST /v1/scenes/{scene}/sample HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\ncontent-length: 100\r\n\r\n{{"
        );
        if s.write_all(head.as_bytes()).await.is_err() {
            continue;
        }
        let mut buf = [0u8; 512];
        loop {
            tokio::select! {
                () = stop.cancelled() => return,
                r = s.read(&mut buf) => {
                    if let Ok(n) = r && n > 0 && buf[..n].starts_with(b"HTTP/1.1 408") {
                        c.slow_408.fetch_add(1, Ordering::Relaxed);
                    }
                    break; // answered or closed: reconnect
                }
                () = tokio::time::sleep(Duration::from_secs(1)) => {
                    if s.write_all(b" ").await.is_err() {
                        break;
                    }
                }
            }
        }
    }
}

fn sample_body(points: usize) -> String {
    let mut s = String::from("{\"points\":[");
    for i in 0..points {
        if i > 0 {
            s.push(',');
        }
        let x = (i % 200) as f64 * 1.25;
        let z = (i / 200) as f64 * 0.75;
        s.push_str(&format!("[{x},{z}]"));
    }
    s.push_str("],\"fields\":[\"height\",\"normal\",\"displacement\"]}");
    s
}

async fn http_non_reader(
    src: Ipv4Addr,
    to: SocketAddr,
    scene: String,
    body: Arc<String>,
    stop: CancellationToken,
    c: Arc<Counters>,
) {
    let Ok(mut s) = connect_from(src, to).await else {
        return;
    };
    let head = format!(
        "POST /v1/scenes/{scene}/sample HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\ncontent-length: {}\r\n\r\n",
        body.len()
    );
    if s.write_all(head.as_bytes()).await.is_err() || s.write_all(body.as_bytes()).await.is_err() {
        return;
    }
    // Never read; notice when the server gives up (a write of ours then fails).
    loop {
        tokio::select! {
            () = stop.cancelled() => return,
            () = tokio::time::sleep(Duration::from_millis(500)) => {
                // Peek at the socket's state without reading its data: a reset or FIN shows as
                // a failed zero-length check via `peer_addr` after the server closes.
                if s.write_all(b"\r\n").await.is_err() {
                    c.non_readers_cut.fetch_add(1, Ordering::Relaxed);
                    return;
                }
            }
        }
    }
}

async fn ws_non_reader(
    src: Ipv4Addr,
    to: SocketAddr,
    scene: String,
    stop: CancellationToken,
    c: Arc<Counters>,
) {
    let Ok(tcp) = connect_from(src, to).await else {
        return;
    };
    let url = format!("ws://{to}/v1/scenes/{scene}/stream");
    let Ok((mut ws, _)) = tokio_tungstenite::client_async(url, tcp).await else {
        return;
    };
    use tokio_tungstenite::tungstenite::Message;
    let sub = r#"{"type":"subscribe","ticks":true}"#;
    if ws.send(Message::text(sub)).await.is_err() {
        return;
    }
    let sample = r#"{"type":"sample","id":1,"points":[[0,0],[1,1],[2,2],[3,3],[4,4],[5,5],[6,6],[7,7]],"fields":["height","normal","displacement"]}"#;
    loop {
        tokio::select! {
            () = stop.cancelled() => return,
            () = tokio::time::sleep(Duration::from_millis(50)) => {
                // Queries keep the answers coming; none is read.
                if tokio::time::timeout(Duration::from_secs(1), ws.send(Message::text(sample))).await.map_or(true, |r| r.is_err()) {
                    c.non_readers_cut.fetch_add(1, Ordering::Relaxed);
                    return;
                }
            }
        }
    }
}

async fn flood(url: String, rate: f64, stop: CancellationToken, c: Arc<Counters>) {
    let every = Duration::from_secs_f64(1.0 / rate);
    let mut next = tokio::time::Instant::now();
    let Ok(client) = reqwest::Client::builder()
        .no_proxy()
        .local_address(IpAddr::V4(Ipv4Addr::new(127, 0, 4, 1)))
        .pool_max_idle_per_host(1)
        .timeout(Duration::from_secs(5))
        .build()
    else {
        return;
    };
    while !stop.is_cancelled() {
        tokio::time::sleep_until(next).await;
        next += every;
        match client.get(&url).send().await {
            Ok(r) if r.status().as_u16() == 429 => {
                c.flood_429.fetch_add(1, Ordering::Relaxed);
                let _ = r.bytes().await;
            }
            Ok(r) if r.status().is_success() => {
                c.flood_ok.fetch_add(1, Ordering::Relaxed);
                let _ = r.bytes().await;
            }
            _ => tokio::time::sleep(Duration::from_millis(10)).await,
        }
    }
}

async fn idle(to: SocketAddr, n: usize, stop: CancellationToken, c: Arc<Counters>) {
    let src = Ipv4Addr::new(127, 0, 5, 1);
    let mut held = Vec::new();
    let mut pending = tokio::task::JoinSet::new();
    for _ in 0..n {
        if stop.is_cancelled() {
            break;
        }
        while pending.len() >= 256 {
            if let Some(Ok(Some(s))) = pending.join_next().await {
                held.push(s);
            }
        }
        let c = c.clone();
        pending.spawn(async move {
            let mut s = connect_from(src, to).await.ok()?;
            // A refused connection is answered at once; a held one says nothing.
            let mut buf = [0u8; 64];
            match tokio::time::timeout(Duration::from_millis(300), s.read(&mut buf)).await {
                Ok(_) => {
                    c.idle_refused.fetch_add(1, Ordering::Relaxed);
                    None
                }
                Err(_) => Some(s),
            }
        });
    }
    while let Some(r) = pending.join_next().await {
        if let Ok(Some(s)) = r {
            held.push(s);
        }
    }
    c.idle_held.store(held.len() as u64, Ordering::Relaxed);
    stop.cancelled().await;
    drop(held);
}

impl std::fmt::Display for HostileReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let l = |f: &mut std::fmt::Formatter<'_>, name: &str, l: &Latency| {
            writeln!(
                f,
                "{name:<10} {:>6} sent {:>6} ok {:>5} failed   p50 {:>7.2} ms  p99 {:>7.2} ms  max {:>7.2} ms",
                l.sent, l.ok, l.failed, l.p50_ms, l.p99_ms, l.max_ms
            )
        };
        l(f, "baseline", &self.baseline)?;
        l(f, "during", &self.during)?;
        l(f, "probes", &self.probes)?;
        let flood_rate = (self.flood_ok + self.flood_429) as f64 / self.attack_s.max(1e-9);
        writeln!(
            f,
            "slow bodies: {} sockets, {} answered 408 | non-readers cut: {} | flood: {} ok, {} x 429 ({flood_rate:.0} req/s sent and answered) | idle: {} refused, {} held",
            self.slow_body_sockets,
            self.slow_body_408,
            self.non_readers_cut,
            self.flood_ok,
            self.flood_429,
            self.idle_refused,
            self.idle_held
        )?;
        match self.slow_lane {
            Some(c) => writeln!(
                f,
                "slow lane: {} demotions, {} connections served there",
                c.demoted, c.connections
            )?,
            None => writeln!(f, "slow lane: not reported by /metrics")?,
        }
        writeln!(
            f,
            "attackers at {} priority for {:.0} s",
            self.attacker_priority, self.attack_s
        )?;
        writeln!(
            f,
            "server RSS: {:.0} MiB at start, {:.0} MiB peak, {:.0} MiB after",
            self.rss_start_mb, self.rss_peak_mb, self.rss_after_mb
        )?;
        for m in &self.failures {
            writeln!(f, "FAILED: {m}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn slow_lane_counts_sum_every_reason() {
        let page = "# TYPE swell_peers_demoted_total counter\n\
            swell_peers_demoted_total{why=\"rate\"} 1\n\
            swell_peers_demoted_total{why=\"slow_body\"} 8\n\
            swell_http_slow_lane_connections_total 16379\n\
            swell_http_requests_total{route=\"x\"} 5\n";
        let c = super::slow_lane_counts(page).unwrap();
        assert_eq!((c.demoted, c.connections), (9, 16379));
        assert!(super::slow_lane_counts("swell_http_requests_total 5\n").is_none());
    }
}
