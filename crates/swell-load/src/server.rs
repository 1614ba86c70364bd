//! Talking to the server outside the load itself: the preflight that fails fast with a reason,
//! the admin setup of `--spawn-bodies`, and `/proc` readings of a server process on this machine.

use std::time::{Duration, Instant};

use reqwest::StatusCode;
use serde::{Deserialize, Serialize};

use crate::cli::Options;
use crate::http::chain;

/// Why a run could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// Nothing answered at the URL.
    #[error("cannot reach {url}: {reason}")]
    Unreachable {
        /// The URL tried.
        url: String,
        /// The transport's reason.
        reason: String,
    },
    /// Something answered, but not as a Swell server.
    #[error("{url} answered {status} to GET /healthz: is it a Swell server?")]
    NotSwell {
        /// The URL tried.
        url: String,
        /// What it answered.
        status: u16,
    },
    /// The scene does not exist on the server.
    #[error("scene {scene:?} is not on the server (it has: {available})")]
    UnknownScene {
        /// The scene asked for.
        scene: String,
        /// The server's scene ids, comma separated.
        available: String,
    },
    /// Setup (admin requests, WebSocket upgrades, clock reading) failed.
    #[error("{0}")]
    Setup(String),
}

/// What the run needs to know about the scene.
#[derive(Debug, Clone, Serialize)]
pub struct SceneInfo {
    /// Tick frames per second of scene time.
    pub tick_hz: f64,
    /// Clock rate (scene seconds per second).
    pub rate: f64,
    /// Whether the clock is paused.
    pub paused: bool,
    /// Floating bodies in the scene when the run started.
    pub body_ids: Vec<u64>,
}

#[derive(Deserialize)]
struct Clock {
    tick_hz: f64,
    rate: f64,
    paused: bool,
}

#[derive(Deserialize)]
struct Detail {
    clock: Clock,
}

#[derive(Deserialize)]
struct BodyId {
    id: u64,
}

#[derive(Deserialize)]
struct Bodies {
    bodies: Vec<BodyId>,
}

#[derive(Deserialize)]
struct Summary {
    id: String,
}

#[derive(Deserialize)]
struct SceneList {
    scenes: Vec<Summary>,
}

fn setup<E: std::error::Error>(what: &str) -> impl FnOnce(E) -> LoadError + '_ {
    move |e| LoadError::Setup(format!("{what}: {}", chain(&e)))
}

/// Checks the server answers `/healthz` and has the scene; reads its clock and body ids.
///
/// # Errors
/// [`LoadError::Unreachable`], [`LoadError::NotSwell`], [`LoadError::UnknownScene`], or a setup
/// error naming the request that failed.
pub async fn preflight(client: &reqwest::Client, o: &Options) -> Result<SceneInfo, LoadError> {
    let health = client
        .get(format!("{}/healthz", o.url))
        .timeout(Duration::from_secs(3))
        .send()
        .await
        .map_err(|e| LoadError::Unreachable {
            url: o.url.clone(),
            reason: chain(&e),
        })?;
    if !health.status().is_success() {
        return Err(LoadError::NotSwell {
            url: o.url.clone(),
            status: health.status().as_u16(),
        });
    }
    // Every scene of `--scenes` must exist; the first one's clock describes the run.
    for other in o.scenes.iter().skip(1) {
        let r = client
            .get(format!("{}/v1/scenes/{other}", o.url))
            .send()
            .await
            .map_err(setup("GET scene"))?;
        if r.status() == StatusCode::NOT_FOUND {
            return Err(LoadError::UnknownScene {
                scene: other.clone(),
                available: "see GET /v1/scenes".into(),
            });
        }
    }
    let scene_url = format!("{}/v1/scenes/{}", o.url, o.scene);
    let r = client
        .get(&scene_url)
        .send()
        .await
        .map_err(setup("GET scene"))?;
    if r.status() == StatusCode::NOT_FOUND {
        let list: SceneList = client
            .get(format!("{}/v1/scenes", o.url))
            .send()
            .await
            .map_err(setup("GET /v1/scenes"))?
            .json()
            .await
            .map_err(setup("GET /v1/scenes"))?;
        let ids: Vec<String> = list.scenes.into_iter().map(|s| s.id).collect();
        return Err(LoadError::UnknownScene {
            scene: o.scene.clone(),
            available: if ids.is_empty() {
                "no scenes".into()
            } else {
                ids.join(", ")
            },
        });
    }
    if !r.status().is_success() {
        return Err(LoadError::Setup(format!("GET {scene_url}: {}", r.status())));
    }
    let detail: Detail = r.json().await.map_err(setup("scene description"))?;
    Ok(SceneInfo {
        tick_hz: detail.clock.tick_hz,
        rate: detail.clock.rate,
        paused: detail.clock.paused,
        body_ids: body_ids(client, o).await?,
    })
}

/// The ids of the scene's floating bodies.
///
/// # Errors
/// The request failed.
pub async fn body_ids(client: &reqwest::Client, o: &Options) -> Result<Vec<u64>, LoadError> {
    let b: Bodies = client
        .get(format!("{}/v1/scenes/{}/bodies", o.url, o.scene))
        .send()
        .await
        .map_err(setup("GET bodies"))?
        .error_for_status()
        .map_err(setup("GET bodies"))?
        .json()
        .await
        .map_err(setup("GET bodies"))?;
    Ok(b.bodies.into_iter().map(|b| b.id).collect())
}

/// Spawns `o.spawn_bodies` 3 t boats (8 × 3 × 1.5 m box hulls) on a 20 m grid around the centre
/// of `--area`, dropped from 0.5 m, eight requests at a time.
///
/// # Errors
/// The first refusal, with its reason (a rejected token, a full scene).
pub async fn spawn_bodies(client: &reqwest::Client, o: &Options) -> Result<(), LoadError> {
    let token = o.admin_token.clone().unwrap_or_default();
    let n = o.spawn_bodies;
    let cols = (n as f64).sqrt().ceil().max(1.0) as usize;
    let (cx, cz) = ((o.area.x0 + o.area.x1) / 2.0, (o.area.z0 + o.area.z1) / 2.0);
    let url = format!("{}/v1/scenes/{}/bodies", o.url, o.scene);
    let slots = std::sync::Arc::new(tokio::sync::Semaphore::new(8));
    let mut set = tokio::task::JoinSet::new();
    for i in 0..n {
        let x = cx + 20.0 * ((i % cols) as f64 - cols as f64 / 2.0);
        let z = cz + 20.0 * ((i / cols) as f64 - cols as f64 / 2.0);
        let body = serde_json::json!({
            "mass": 3000.0,
            "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
            "position": [x, 0.5, z],
            "yaw": 0.0,
        });
        let (client, url, token, slots) =
            (client.clone(), url.clone(), token.clone(), slots.clone());
        set.spawn(async move {
            let _p = slots.acquire_owned().await.expect("never closed");
            let r = client
                .post(&url)
                .bearer_auth(&token)
                .json(&body)
                .send()
                .await
                .map_err(setup("spawning a body"))?;
            let status = r.status();
            if status.is_success() {
                return Ok(());
            }
            let text = r.text().await.unwrap_or_default();
            Err(LoadError::Setup(match status.as_u16() {
                401 | 403 => format!("spawning bodies: the admin token was refused ({status})"),
                409 => format!("spawning bodies: the scene is full ({status}: {text})"),
                _ => format!("spawning bodies: {status}: {text}"),
            }))
        });
    }
    while let Some(r) = set.join_next().await {
        r.map_err(|e| LoadError::Setup(format!("spawn task: {e}")))??;
    }
    Ok(())
}

/// One reading of a process's CPU time and memory (Linux `/proc`).
#[derive(Debug, Clone, Copy)]
pub struct ProcSample {
    at: Instant,
    cpu_s: f64,
    rss_kib: u64,
    hwm_kib: u64,
}

/// `sysconf(_SC_CLK_TCK)`: 100 on every Linux this runs on (the kernel's USER_HZ).
const CLK_TCK: f64 = 100.0;

impl ProcSample {
    /// Reads `/proc/{pid}/stat` and `/proc/{pid}/status`.
    ///
    /// # Errors
    /// The process is gone or `/proc` is not there.
    pub fn read(pid: u32) -> std::io::Result<Self> {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))?;
        let status = std::fs::read_to_string(format!("/proc/{pid}/status"))?;
        // Fields after the `(comm)`: state is field 3, utime 14, stime 15.
        let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
        let f: Vec<&str> = rest.split_whitespace().collect();
        let tick = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
        let kib = |key: &str| {
            status
                .lines()
                .find_map(|l| l.strip_prefix(key))
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse::<u64>().ok())
                .unwrap_or(0)
        };
        Ok(Self {
            at: Instant::now(),
            cpu_s: (tick(11) + tick(12)) as f64 / CLK_TCK,
            rss_kib: kib("VmRSS:"),
            hwm_kib: kib("VmHWM:"),
        })
    }
}

/// This process's CPU over the window, in cores (1.0 = one core busy): on a machine shared with
/// the server, a load tool near a full core is itself a bottleneck and the figures say so.
pub fn own_cpu_cores(a: Option<ProcSample>, b: Option<ProcSample>) -> Option<f64> {
    let (a, b) = (a?, b?);
    let wall = b.at.duration_since(a.at).as_secs_f64();
    (wall > 0.0).then(|| (b.cpu_s - a.cpu_s) / wall)
}

/// The server process over the run.
#[derive(Debug, Clone, Serialize)]
pub struct ServerProcess {
    /// Its pid.
    pub pid: u32,
    /// CPU time over wall time in the window: 1.0 is one core busy.
    pub cpu_cores: f64,
    /// Resident memory when the window started, MiB.
    pub rss_start_mib: f64,
    /// Resident memory when it ended, MiB.
    pub rss_end_mib: f64,
    /// Peak resident memory of the process's life so far, MiB.
    pub rss_peak_mib: f64,
}

impl ServerProcess {
    /// Between two readings.
    pub fn between(pid: u32, a: ProcSample, b: ProcSample) -> Self {
        let wall = b.at.duration_since(a.at).as_secs_f64().max(1e-9);
        Self {
            pid,
            cpu_cores: (b.cpu_s - a.cpu_s) / wall,
            rss_start_mib: a.rss_kib as f64 / 1024.0,
            rss_end_mib: b.rss_kib as f64 / 1024.0,
            rss_peak_mib: b.hwm_kib as f64 / 1024.0,
        }
    }
}
