//! The command line: what a run can be asked to do, and the checks that turn arguments into a
//! validated [`Options`]. Every rejected combination gets a message naming the flag.

use std::time::Duration;

use clap::{Parser, ValueEnum};

use crate::wire::Wire;

/// What a run sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// `GET /v1/scenes/{scene}/height?x=&z=[&t=]`: one point per request.
    Height,
    /// `POST /v1/scenes/{scene}/sample` with `--points` random points.
    Sample,
    /// `POST /v1/scenes/{scene}/orientation` with `--bodies` random hulls.
    Orientation,
    /// `sample` (or `orientation`, `--query`) messages over `--connections` WebSockets, answers
    /// matched by `id`.
    WsQuery,
    /// `--subscribers` WebSocket subscribers to the scene's tick frames.
    Stream,
    /// A weighted mix of HTTP queries (`--mix`), with `--subscribers` streaming beside it.
    Mixed,
}

impl Mode {
    /// Whether the mode sends HTTP queries.
    pub fn is_http(self) -> bool {
        matches!(
            self,
            Mode::Height | Mode::Sample | Mode::Orientation | Mode::Mixed
        )
    }
}

/// The kind of one query.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum QueryKind {
    /// Single-point height.
    Height,
    /// A batch sample.
    Sample,
    /// A batch of body orientations.
    Orientation,
}

impl QueryKind {
    /// The name used in `--mix` and reports.
    pub fn name(self) -> &'static str {
        match self {
            QueryKind::Height => "height",
            QueryKind::Sample => "sample",
            QueryKind::Orientation => "orientation",
        }
    }
}

/// How requests are issued.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Shape {
    /// Open loop: request `i` is due at `start + i / rate`, whatever happened to earlier ones, and
    /// its latency is measured from that due time. A server that stalls cannot hide its queue
    /// (no coordinated omission). At most `max_in_flight` requests are outstanding; a due request
    /// waits for a slot and the wait counts in its latency.
    OpenLoop {
        /// Requests per second.
        rate: f64,
        /// Outstanding requests at most.
        max_in_flight: usize,
    },
    /// Closed loop: `concurrency` workers, each sending its next request when the previous one
    /// is answered. Measures maximum throughput; latency is from send.
    ClosedLoop {
        /// Workers.
        concurrency: usize,
    },
}

/// Where random points fall: the world rectangle `[x0, x1] × [z0, z1]`, metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Area {
    /// Smallest x.
    pub x0: f64,
    /// Smallest z.
    pub z0: f64,
    /// Largest x.
    pub x1: f64,
    /// Largest z.
    pub z1: f64,
}

/// `swell-load`: load-test a Swell server's HTTP and WebSocket endpoints.
///
/// Open loop with `--rate` (requests on a timetable, latency from the scheduled time), closed
/// loop with `--concurrency` (maximum throughput). Prints a summary on stdout (`--json` for one
/// machine-readable object); a live progress line goes to stderr when it is a terminal; Ctrl-C
/// stops early and prints what was measured so far.
#[derive(Debug, Clone, Parser)]
#[command(version, about, long_about = None)]
pub struct Args {
    /// What to send.
    #[arg(value_enum)]
    pub mode: Mode,
    /// The server's base URL.
    #[arg(long, env = "SWELL_URL", default_value = "http://127.0.0.1:8080")]
    pub url: String,
    /// Scene id.
    #[arg(long, default_value = "open-sea")]
    pub scene: String,
    /// `height`, `sample`, `orientation`, `mixed`: spread the queries evenly over these scene
    /// ids (comma separated, at most 64) instead of `--scene` alone, e.g. to load many scenes
    /// of one server at once.
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Encoding of bodies and WebSocket messages.
    #[arg(long, value_enum, default_value = "json")]
    pub wire: Wire,
    /// Open loop: requests per second, on a fixed timetable.
    #[arg(long, conflicts_with = "concurrency")]
    pub rate: Option<f64>,
    /// Closed loop: workers each waiting for its answer before sending again [default: 16].
    #[arg(long)]
    pub concurrency: Option<usize>,
    /// Open loop: outstanding requests at most (a due request waits for a slot; the wait counts).
    #[arg(long, default_value_t = 1024)]
    pub max_in_flight: usize,
    /// How long to measure (`10s`, `500ms`, `2m`; a bare number is seconds).
    #[arg(long, default_value = "10s", value_parser = parse_duration)]
    pub duration: Duration,
    /// Load before measuring starts (sent, not recorded).
    #[arg(long, default_value = "1s", value_parser = parse_duration)]
    pub warmup: Duration,
    /// Scene time of every query, s [default: omitted, the scene clock's now].
    #[arg(long)]
    pub t: Option<f64>,
    /// Points per sample request [default: 1; 64 in `mixed`].
    #[arg(long)]
    pub points: Option<usize>,
    /// Bodies per orientation request.
    #[arg(long, default_value_t = 1)]
    pub bodies: usize,
    /// Fields of sample requests, comma separated (height, normal, displacement, jacobian,
    /// residual).
    #[arg(long, default_value = "height")]
    pub fields: String,
    /// `ws-query`: the message kind to send.
    #[arg(long, value_enum, default_value = "sample")]
    pub query: QueryKind,
    /// `ws-query`: WebSocket connections (the server runs at most 8 queries at once per socket).
    #[arg(long, default_value_t = 1)]
    pub connections: usize,
    /// Where random points fall: `HALF` (the square ±HALF m) or `x0,z0,x1,z1`.
    #[arg(long, default_value = "1000", value_parser = parse_area, allow_hyphen_values = true)]
    pub area: Area,
    /// Seed of the random points, hulls and mix choices (same seed, same requests).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// `stream`/`mixed`: WebSocket subscribers to the tick frames [default: 10 in `stream`, 0 in
    /// `mixed`].
    #[arg(long)]
    pub subscribers: Option<usize>,
    /// Bodies each subscriber follows (its interest set; 0 = all of the scene's bodies).
    #[arg(long, default_value_t = 0)]
    pub bodies_per_subscriber: usize,
    /// Subscribers also follow the bodies inside this rectangle, `x0,z0,x1,z1` (interest by
    /// area, re-evaluated by the server every tick).
    #[arg(long, value_parser = parse_area, allow_hyphen_values = true)]
    pub region: Option<Area>,
    /// Subscribers ask for compact body states (`Subscribe.compact`; needs `--wire protobuf`).
    #[arg(long)]
    pub compact: bool,
    /// `mixed`: weights, e.g. `height=90,sample=9,orientation=1`.
    #[arg(long, default_value = "height=90,sample=9,orientation=1", value_parser = parse_mix)]
    pub mix: Mix,
    /// Spawn this many floating bodies in the scene before the run (needs `--admin-token`).
    #[arg(long, default_value_t = 0)]
    pub spawn_bodies: usize,
    /// Admin bearer token (for `--spawn-bodies`).
    #[arg(long, env = "SWELL_ADMIN_TOKEN", hide_env_values = true)]
    pub admin_token: Option<String>,
    /// Also run the same load shape against `/healthz` and report the ratio.
    #[arg(long)]
    pub ceiling: bool,
    /// The server's process id (same machine): report its CPU share and resident memory.
    #[arg(long)]
    pub server_pid: Option<u32>,
    /// Per-request timeout.
    #[arg(long, default_value = "10s", value_parser = parse_duration)]
    pub timeout: Duration,
    /// Decode every answer and check it (point and body counts); costs client CPU.
    #[arg(long)]
    pub validate: bool,
    /// Exit with status 1 if any request failed or any tick was missed.
    #[arg(long)]
    pub fail_on_errors: bool,
    /// Print one JSON object on stdout instead of the text summary.
    #[arg(long)]
    pub json: bool,
}

/// Weights of the query kinds in `mixed`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Mix(pub Vec<(QueryKind, u32)>);

/// A run, validated.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Options {
    /// What to send.
    pub mode: Mode,
    /// Base URL without a trailing slash.
    pub url: String,
    /// Scene id (with `--scenes`, the first of them).
    pub scene: String,
    /// The scenes HTTP queries spread over (`--scenes`); empty: `scene` alone.
    pub scenes: Vec<String>,
    /// Encoding.
    pub wire: Wire,
    /// Open or closed loop.
    pub shape: Shape,
    /// Measured time.
    #[serde(serialize_with = "secs")]
    pub duration: Duration,
    /// Unrecorded time before it.
    #[serde(serialize_with = "secs")]
    pub warmup: Duration,
    /// Fixed scene time, or `None` for now.
    pub t: Option<f64>,
    /// Points per sample request.
    pub points: usize,
    /// Bodies per orientation request.
    pub bodies: usize,
    /// Sample fields.
    pub fields: Vec<String>,
    /// `ws-query` message kind.
    pub query: QueryKind,
    /// `ws-query` connections.
    pub connections: usize,
    /// Where points fall.
    pub area: Area,
    /// Seed.
    pub seed: u64,
    /// Stream subscribers.
    pub subscribers: usize,
    /// Interest set size per subscriber (0 = all).
    pub bodies_per_subscriber: usize,
    /// Interest by area.
    pub region: Option<Area>,
    /// Compact body states.
    pub compact: bool,
    /// `mixed` weights.
    pub mix: Mix,
    /// Bodies to spawn first.
    pub spawn_bodies: usize,
    /// Admin token.
    #[serde(skip)]
    pub admin_token: Option<String>,
    /// Run against `/healthz` too.
    pub ceiling: bool,
    /// Server process to watch.
    pub server_pid: Option<u32>,
    /// Per-request timeout.
    #[serde(serialize_with = "secs")]
    pub timeout: Duration,
    /// Check every answer.
    pub validate: bool,
}

fn secs<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

/// Limits that keep a run from exhausting the machine it runs on, not the server: the tool is
/// meant for loopback and lab targets.
const MAX_RATE: f64 = 1_000_000.0;
const MAX_CONCURRENCY: usize = 10_000;
const MAX_SUBSCRIBERS: usize = 20_000;
const MAX_POINTS: usize = 1_000_000;
const MAX_SPAWN: usize = 100_000;
const MAX_SCENES: usize = 64;

/// A rejected combination of arguments: the flag and what was wrong.
#[derive(Debug, thiserror::Error)]
#[error("{flag}: {message}")]
pub struct ArgError {
    /// The flag, as typed (`--rate`).
    pub flag: &'static str,
    /// What was wrong and what is allowed.
    pub message: String,
}

fn bad(flag: &'static str, message: impl Into<String>) -> ArgError {
    ArgError {
        flag,
        message: message.into(),
    }
}

impl Args {
    /// Checks the combination and fills the mode-dependent defaults.
    ///
    /// # Errors
    /// An [`ArgError`] naming the first flag that is out of range or does not apply to the mode.
    pub fn into_options(self) -> Result<Options, ArgError> {
        let mode = self.mode;
        let url = self.url.trim_end_matches('/').to_owned();
        if !(url.starts_with("http://") || url.starts_with("https://")) {
            return Err(bad(
                "--url",
                format!("{url:?} is not an http:// URL (e.g. http://127.0.0.1:8080)"),
            ));
        }
        if url.starts_with("https://") {
            return Err(bad(
                "--url",
                "https is not supported (this build has no TLS); point it at the server or a \
                 plain-HTTP port of its load balancer",
            ));
        }
        if self.scene.is_empty() {
            return Err(bad("--scene", "empty scene id"));
        }
        if !self.scenes.is_empty() {
            if !mode.is_http() {
                return Err(bad(
                    "--scenes",
                    "spreads HTTP queries: use it with height, sample, orientation or mixed",
                ));
            }
            if self.scenes.len() > MAX_SCENES || self.scenes.iter().any(String::is_empty) {
                return Err(bad(
                    "--scenes",
                    format!("1..={MAX_SCENES} non-empty scene ids, comma separated"),
                ));
            }
            if self.spawn_bodies > 0 || self.subscribers.is_some_and(|s| s > 0) {
                return Err(bad(
                    "--scenes",
                    "bodies and subscribers follow one scene: use --scene with them",
                ));
            }
        }
        let scene = self.scenes.first().cloned().unwrap_or(self.scene);
        let shape = match (self.rate, self.concurrency) {
            (Some(rate), _) => {
                if !(rate.is_finite() && rate > 0.0 && rate <= MAX_RATE) {
                    return Err(bad(
                        "--rate",
                        format!("{rate} is not in (0, {MAX_RATE}] requests per second"),
                    ));
                }
                if self.max_in_flight == 0 || self.max_in_flight > MAX_CONCURRENCY {
                    return Err(bad(
                        "--max-in-flight",
                        format!("must be 1..={MAX_CONCURRENCY}"),
                    ));
                }
                Shape::OpenLoop {
                    rate,
                    max_in_flight: self.max_in_flight,
                }
            }
            (None, c) => {
                let concurrency = c.unwrap_or(16);
                if concurrency == 0 || concurrency > MAX_CONCURRENCY {
                    return Err(bad(
                        "--concurrency",
                        format!("{concurrency} is not in 1..={MAX_CONCURRENCY}"),
                    ));
                }
                Shape::ClosedLoop { concurrency }
            }
        };
        if self.duration.is_zero() {
            return Err(bad("--duration", "must be longer than zero"));
        }
        if let Some(t) = self.t
            && !t.is_finite()
        {
            return Err(bad("--t", format!("{t} is not a finite scene time")));
        }
        let points = self
            .points
            .unwrap_or(if mode == Mode::Mixed { 64 } else { 1 });
        if points == 0 || points > MAX_POINTS {
            return Err(bad(
                "--points",
                format!("{points} is not in 1..={MAX_POINTS}"),
            ));
        }
        if self.bodies == 0 || self.bodies > MAX_POINTS {
            return Err(bad(
                "--bodies",
                format!("{} is not in 1..={MAX_POINTS}", self.bodies),
            ));
        }
        let fields: Vec<String> = self
            .fields
            .split(',')
            .map(|f| f.trim().to_owned())
            .filter(|f| !f.is_empty())
            .collect();
        const FIELDS: [&str; 5] = ["height", "normal", "displacement", "jacobian", "residual"];
        if fields.is_empty() {
            return Err(bad("--fields", "no field named"));
        }
        if let Some(f) = fields.iter().find(|f| !FIELDS.contains(&f.as_str())) {
            return Err(bad(
                "--fields",
                format!("{f:?} is not a field (one of {})", FIELDS.join(", ")),
            ));
        }
        if self.query == QueryKind::Height && mode == Mode::WsQuery {
            return Err(bad(
                "--query",
                "the stream answers sample and orientation messages; a single-point height is a \
                 one-point sample",
            ));
        }
        if self.connections == 0 || self.connections > MAX_CONCURRENCY {
            return Err(bad(
                "--connections",
                format!("{} is not in 1..={MAX_CONCURRENCY}", self.connections),
            ));
        }
        if self.connections != 1 && mode != Mode::WsQuery {
            return Err(bad("--connections", "applies to ws-query only"));
        }
        let subscribers = self.subscribers.unwrap_or(match mode {
            Mode::Stream => 10,
            _ => 0,
        });
        if subscribers > MAX_SUBSCRIBERS {
            return Err(bad(
                "--subscribers",
                format!("{subscribers} is more than {MAX_SUBSCRIBERS}"),
            ));
        }
        if subscribers > 0 && !matches!(mode, Mode::Stream | Mode::Mixed) {
            return Err(bad("--subscribers", "applies to stream and mixed only"));
        }
        if mode == Mode::Stream && subscribers == 0 {
            return Err(bad("--subscribers", "stream needs at least one subscriber"));
        }
        if mode == Mode::Stream && (self.rate.is_some() || self.concurrency.is_some()) {
            return Err(bad(
                "--rate/--concurrency",
                "stream sends no requests: the scene's tick rate sets the frame rate",
            ));
        }
        if self.region.is_some() && subscribers == 0 {
            return Err(bad("--region", "applies to stream subscribers only"));
        }
        if self.compact && (subscribers == 0 || self.wire != Wire::Protobuf) {
            return Err(bad(
                "--compact",
                "compact body states are for stream subscribers with --wire protobuf",
            ));
        }
        if self.spawn_bodies > MAX_SPAWN {
            return Err(bad(
                "--spawn-bodies",
                format!("{} is more than {MAX_SPAWN}", self.spawn_bodies),
            ));
        }
        if self.spawn_bodies > 0 && self.admin_token.is_none() {
            return Err(bad(
                "--spawn-bodies",
                "needs --admin-token (or SWELL_ADMIN_TOKEN): spawning is an admin request",
            ));
        }
        if self.ceiling && !mode.is_http() {
            return Err(bad(
                "--ceiling",
                "compares HTTP queries with GET /healthz: use it with height, sample, \
                 orientation or mixed",
            ));
        }
        if self.timeout.is_zero() {
            return Err(bad("--timeout", "must be longer than zero"));
        }
        Ok(Options {
            mode,
            url,
            scene,
            scenes: self.scenes,
            wire: self.wire,
            shape,
            duration: self.duration,
            warmup: self.warmup,
            t: self.t,
            points,
            bodies: self.bodies,
            fields,
            query: self.query,
            connections: self.connections,
            area: self.area,
            seed: self.seed,
            subscribers,
            bodies_per_subscriber: self.bodies_per_subscriber,
            region: self.region,
            compact: self.compact,
            mix: self.mix,
            spawn_bodies: self.spawn_bodies,
            admin_token: self.admin_token,
            ceiling: self.ceiling,
            server_pid: self.server_pid,
            timeout: self.timeout,
            validate: self.validate,
        })
    }
}

/// Parses `10s`, `250ms`, `2m`, `1h` or a bare number of seconds.
///
/// # Errors
/// A message naming the accepted forms.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let s = s.trim();
    let (num, scale) = if let Some(n) = s.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = s.strip_suffix('s') {
        (n, 1.0)
    } else if let Some(n) = s.strip_suffix('m') {
        (n, 60.0)
    } else if let Some(n) = s.strip_suffix('h') {
        (n, 3600.0)
    } else {
        (s, 1.0)
    };
    let v: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a duration (e.g. 10s, 500ms, 2m, or seconds)"))?;
    let secs = v * scale;
    if !(secs.is_finite() && (0.0..=86_400.0).contains(&secs)) {
        return Err(format!("{s:?} is not between 0 and 24 h"));
    }
    Ok(Duration::from_secs_f64(secs))
}

/// Parses `HALF` (the square ±HALF) or `x0,z0,x1,z1`.
///
/// # Errors
/// A message naming the accepted forms.
pub fn parse_area(s: &str) -> Result<Area, String> {
    let nums: Result<Vec<f64>, _> = s.split(',').map(|p| p.trim().parse::<f64>()).collect();
    let nums = nums.map_err(|_| format!("{s:?} is not HALF or x0,z0,x1,z1 (metres)"))?;
    let area = match nums[..] {
        [h] => Area {
            x0: -h,
            z0: -h,
            x1: h,
            z1: h,
        },
        [x0, z0, x1, z1] => Area { x0, z0, x1, z1 },
        _ => return Err(format!("{s:?} is not HALF or x0,z0,x1,z1 (metres)")),
    };
    let ok = [area.x0, area.z0, area.x1, area.z1]
        .iter()
        .all(|v| v.is_finite() && v.abs() <= 1e9);
    if !ok || area.x0 > area.x1 || area.z0 > area.z1 {
        return Err(format!(
            "{s:?}: need finite |values| <= 1e9 with x0 <= x1 and z0 <= z1"
        ));
    }
    Ok(area)
}

/// Parses `height=90,sample=9,orientation=1`.
///
/// # Errors
/// A message naming the bad entry.
pub fn parse_mix(s: &str) -> Result<Mix, String> {
    let mut out: Vec<(QueryKind, u32)> = Vec::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, w) = part
            .split_once('=')
            .ok_or_else(|| format!("{part:?} is not KIND=WEIGHT"))?;
        let kind = QueryKind::from_str(name.trim(), true)
            .map_err(|_| format!("{name:?} is not a query kind (height, sample, orientation)"))?;
        let w: u32 = w
            .trim()
            .parse()
            .map_err(|_| format!("{w:?} is not a whole-number weight"))?;
        if out.iter().any(|(k, _)| *k == kind) {
            return Err(format!("{name} appears twice"));
        }
        out.push((kind, w));
    }
    if out.iter().map(|(_, w)| u64::from(*w)).sum::<u64>() == 0 {
        return Err("the weights add up to zero".into());
    }
    Ok(Mix(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(extra: &[&str]) -> Result<Options, String> {
        let mut v = vec!["swell-load"];
        v.extend_from_slice(extra);
        Args::try_parse_from(v)
            .map_err(|e| e.to_string())?
            .into_options()
            .map_err(|e| e.to_string())
    }

    #[test]
    fn defaults_are_a_closed_loop_height_run_at_now() {
        let o = args(&["height"]).unwrap();
        assert_eq!(o.shape, Shape::ClosedLoop { concurrency: 16 });
        assert_eq!(o.t, None);
        assert_eq!(o.points, 1);
        assert_eq!(o.url, "http://127.0.0.1:8080");
        assert_eq!(o.duration, Duration::from_secs(10));
        let m = args(&["mixed"]).unwrap();
        assert_eq!(m.points, 64);
        assert_eq!(m.subscribers, 0);
        assert_eq!(args(&["stream"]).unwrap().subscribers, 10);
    }

    #[test]
    fn bad_combinations_name_the_flag() {
        for (argv, flag) in [
            (&["height", "--rate", "0"][..], "--rate"),
            (&["height", "--rate", "nan"][..], "--rate"),
            (&["sample", "--points", "0"][..], "--points"),
            (&["height", "--subscribers", "3"][..], "--subscribers"),
            (&["stream", "--ceiling"][..], "--ceiling"),
            (&["stream", "--rate", "10"][..], "--rate"),
            (&["stream", "--spawn-bodies", "5"][..], "--spawn-bodies"),
            (&["sample", "--fields", "height,colour"][..], "--fields"),
            (&["height", "--url", "localhost:8080"][..], "--url"),
            (&["height", "--t", "inf"][..], "--t"),
            (&["ws-query", "--query", "height"][..], "--query"),
            (&["height", "--connections", "4"][..], "--connections"),
            (&["stream", "--scenes", "a,b"][..], "--scenes"),
            (&["height", "--scenes", "a,,b"][..], "--scenes"),
        ] {
            let e = args(argv).expect_err(&format!("{argv:?} accepted"));
            assert!(e.contains(flag), "{argv:?}: {e}");
        }
        // clap-level errors name the flag too.
        assert!(
            args(&["height", "--duration", "ten"])
                .unwrap_err()
                .contains("--duration")
        );
        assert!(args(&["height", "--rate", "5", "--concurrency", "2"]).is_err());
        assert!(
            args(&["mixed", "--mix", "height=0"])
                .unwrap_err()
                .contains("zero")
        );
        assert!(
            args(&["mixed", "--mix", "heights=3"])
                .unwrap_err()
                .contains("heights")
        );
    }

    #[test]
    fn durations_areas_and_mixes_parse() {
        assert_eq!(parse_duration("250ms").unwrap(), Duration::from_millis(250));
        assert_eq!(parse_duration("2m").unwrap(), Duration::from_secs(120));
        assert_eq!(parse_duration("1.5").unwrap(), Duration::from_millis(1500));
        assert!(parse_duration("-1s").is_err());
        assert_eq!(
            parse_area("-5,0,5,20").unwrap(),
            Area {
                x0: -5.0,
                z0: 0.0,
                x1: 5.0,
                z1: 20.0
            }
        );
        assert!(parse_area("5,0,-5,20").is_err());
        let m = parse_mix("height=90, sample=9,orientation=1").unwrap();
        assert_eq!(
            m.0,
            vec![
                (QueryKind::Height, 90),
                (QueryKind::Sample, 9),
                (QueryKind::Orientation, 1)
            ]
        );
    }
}
