//! The reference for fleet bodies: a scene's body log recorded from Redis as it is written, and
//! replayed in this one process through the crate's public body API (`SceneBodies`), with the
//! sequencing rule spelled out here again: commands wait by (tick, stream order); at watermark
//! `W` the world steps to each due command's tick, applies it, then steps to `W`. Replicas that
//! received the log in batches, over reconnects, from snapshots and across a failover must hold
//! exactly the states of this single, uninterrupted pass.
#![allow(dead_code, unreachable_pub)]

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use redis::AsyncCommands as _;
use redis::streams::{StreamRangeReply, StreamReadOptions, StreamReadReply};
use serde_json::Value;
use swell::bodies::{BodyState, SceneBodies, Sea};
use swell::scene::{Scene, SceneSpec};
use swell::store::bodies::BodyCmd;

/// One log entry: its id and its fields (`cmd`, `tick`, `nonce` or `wm`, `fence`).
#[derive(Debug, Clone)]
pub struct Entry {
    pub id: String,
    pub fields: BTreeMap<String, String>,
}

impl Entry {
    pub fn watermark(&self) -> Option<i64> {
        self.fields.get("wm").and_then(|w| w.parse().ok())
    }
    pub fn fence(&self) -> Option<u64> {
        self.fields.get("fence").and_then(|w| w.parse().ok())
    }
    /// The command and its apply tick.
    pub fn command(&self) -> Option<(i64, BodyCmd)> {
        let cmd = serde_json::from_str(self.fields.get("cmd")?).expect("a readable command");
        Some((self.fields.get("tick")?.parse().ok()?, cmd))
    }
}

#[derive(Default)]
struct Log {
    entries: Vec<Entry>,
    /// Set if an entry was trimmed before the recorder read it (the reference would be wrong).
    lost: Option<String>,
}

/// Follows `swell:bodies:<scene>:log` from its first entry, keeping every entry (the replicas
/// trim the stream behind their snapshots; the recorder keeps the whole history).
pub struct Recorder {
    log: Arc<Mutex<Log>>,
    task: tokio::task::JoinHandle<()>,
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.task.abort();
    }
}

impl Recorder {
    /// Starts recording (call before the first body command, so nothing is trimmed yet).
    pub async fn start(redis_url: &str, scene: &str) -> Recorder {
        let client = redis::Client::open(redis_url).unwrap();
        let config = redis::AsyncConnectionConfig::new()
            .set_response_timeout(Some(Duration::from_secs(5)))
            .set_connection_timeout(Some(Duration::from_secs(2)));
        let mut conn = client
            .get_multiplexed_async_connection_with_config(&config)
            .await
            .expect("the recorder connects to Redis");
        let log = Arc::new(Mutex::new(Log::default()));
        let key = format!("swell:bodies:{scene}:log");
        let shared = log.clone();
        let task = tokio::spawn(async move {
            let opts = StreamReadOptions::default().block(200).count(1000);
            let mut last = "0-0".to_owned();
            loop {
                let reply: StreamReadReply =
                    match conn.xread_options(&[&key], &[&last], &opts).await {
                        Ok(Some(r)) => r,
                        Ok(None) => continue,
                        Err(e) => {
                            shared.lock().unwrap().lost = Some(format!("XREAD failed: {e}"));
                            return;
                        }
                    };
                let ids: Vec<_> = reply.keys.into_iter().flat_map(|k| k.ids).collect();
                if ids.is_empty() {
                    continue;
                }
                // The last entry read must still be there: a trim removes a prefix, so then
                // nothing between it and this batch was trimmed unseen.
                if last != "0-0" {
                    let still: StreamRangeReply = conn.xrange(&key, &last, &last).await.unwrap();
                    if still.ids.is_empty() {
                        shared.lock().unwrap().lost = Some(format!(
                            "entries after {last} were trimmed before being read"
                        ));
                        return;
                    }
                }
                let mut g = shared.lock().unwrap();
                for e in ids {
                    let mut fields = BTreeMap::new();
                    for f in ["cmd", "tick", "nonce", "wm", "fence"] {
                        if let Some(v) = e.get::<String>(f) {
                            fields.insert(f.to_owned(), v);
                        }
                    }
                    last = e.id.clone();
                    g.entries.push(Entry { id: e.id, fields });
                }
            }
        });
        Recorder { log, task }
    }

    /// Every entry recorded so far, in stream order. Panics if any was lost.
    pub fn entries(&self) -> Vec<Entry> {
        let g = self.log.lock().unwrap();
        assert!(
            g.lost.is_none(),
            "the log recorder missed entries: {:?}",
            g.lost
        );
        g.entries.clone()
    }

    /// Waits (at most 10 s) until a watermark `>= tick` is recorded; returns the entries.
    pub async fn until_watermark(&self, tick: i64) -> Vec<Entry> {
        let start = Instant::now();
        loop {
            let entries = self.entries();
            if entries
                .iter()
                .filter_map(Entry::watermark)
                .any(|w| w >= tick)
            {
                return entries;
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "no watermark >= {tick} in the recorded log ({} entries)",
                entries.len()
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
}

/// The states after every watermark of `entries`, by tick, replayed in this process on the scene
/// built from `spec` (the scene's spec as a replica serves it).
pub fn replay(entries: &[Entry], spec: &Value) -> BTreeMap<i64, Vec<BodyState>> {
    let scene = Scene::build("replay", SceneSpec::from_value(spec.clone()).unwrap()).unwrap();
    let (hz, g) = (scene.spec.tick_hz, scene.spec.surface.gravity);
    let mut pending: BTreeMap<(i64, usize), BodyCmd> = BTreeMap::new();
    let mut world: Option<SceneBodies> = None;
    let mut out = BTreeMap::new();
    for (i, e) in entries.iter().enumerate() {
        if let Some((tick, cmd)) = e.command() {
            pending.insert((tick, i), cmd);
        } else if let Some(w) = e.watermark() {
            let due: Vec<(i64, usize)> =
                pending.range(..=(w, usize::MAX)).map(|(k, _)| *k).collect();
            for k in due {
                let cmd = pending.remove(&k).unwrap();
                let tick = k.0;
                let b = world.get_or_insert_with(|| SceneBodies::new(tick, hz, g).unwrap());
                b.advance_to(tick, Sea::Direct(&scene.surface), hz, g);
                match cmd {
                    BodyCmd::Spawn(req) => {
                        b.spawn(&req).expect("a logged spawn applies");
                    }
                    BodyCmd::Remove { id } => {
                        b.remove(id);
                    }
                    BodyCmd::Input { id, mut input } => {
                        if input.from_tick.is_some_and(|t| t <= tick) {
                            input.from_tick = None;
                        }
                        // An input for a body removed meanwhile is refused everywhere alike.
                        let _ = b.input(id, &input);
                    }
                    BodyCmd::Impact(impact) => b.feel(impact),
                }
            }
            if let Some(b) = world.as_mut() {
                b.advance_to(w, Sea::Direct(&scene.surface), hz, g);
                out.insert(w, b.states(None));
            }
        }
    }
    out
}

/// Whether two JSON values are equal with every number compared by its f64 bits (so `-0.0` and
/// `0.0` differ, as they do on the wire).
pub fn same_bits(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => match (x.as_u64(), y.as_u64()) {
            (Some(p), Some(q)) => p == q,
            _ => x.as_f64().map(f64::to_bits) == y.as_f64().map(f64::to_bits),
        },
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same_bits(p, q))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len()
                && x.iter()
                    .all(|(k, v)| y.get(k).is_some_and(|w| same_bits(v, w)))
        }
        _ => a == b,
    }
}

/// Asserts that `bodies` (a replica's `bodies` JSON) is the reference's states at `tick`.
pub fn assert_replayed(
    reference: &BTreeMap<i64, Vec<BodyState>>,
    tick: i64,
    bodies: &Value,
    what: &str,
) {
    let want = reference
        .get(&tick)
        .unwrap_or_else(|| panic!("{what}: no watermark {tick} in the replayed log"));
    let want = serde_json::to_value(want).unwrap();
    // `GET …/bodies` also describes each body (mass, hull, spawn tick, what a re-anchor
    // carried it in with); the states are what is compared.
    let mut bodies = bodies.clone();
    if let Some(list) = bodies.as_array_mut() {
        for b in list.iter_mut().filter_map(Value::as_object_mut) {
            for k in ["mass", "hull", "spawn_tick", "carried"] {
                b.remove(k);
            }
        }
    }
    let bodies = &bodies;
    assert!(
        same_bits(bodies, &want),
        "{what}: states at tick {tick} differ from the single-process replay\nreplica: {bodies}\nreplay:  {want}"
    );
}

/// Asserts that every acknowledged input `(force z, apply tick)` is an input command of
/// `entries` with that force and tick.
pub fn replay_has_inputs(entries: &[Entry], acknowledged: &[(f64, i64)]) {
    let logged: Vec<(u64, i64)> = entries
        .iter()
        .filter_map(Entry::command)
        .filter_map(|(tick, c)| match c {
            BodyCmd::Input { input, .. } => Some((input.force[2].to_bits(), tick)),
            _ => None,
        })
        .collect();
    for (force, tick) in acknowledged {
        assert!(
            logged.contains(&(force.to_bits(), *tick)),
            "the acknowledged input with force z = {force} (tick {tick}) is not in the log"
        );
    }
}

/// A connection of the test's own to Redis.
pub async fn connect(redis_url: &str) -> redis::aio::MultiplexedConnection {
    let config = redis::AsyncConnectionConfig::new()
        .set_response_timeout(Some(Duration::from_secs(5)))
        .set_connection_timeout(Some(Duration::from_secs(2)));
    redis::Client::open(redis_url)
        .unwrap()
        .get_multiplexed_async_connection_with_config(&config)
        .await
        .expect("the test connects to Redis")
}

/// `GET key`.
pub async fn get(redis_url: &str, key: &str) -> Option<String> {
    connect(redis_url).await.get(key).await.unwrap()
}
