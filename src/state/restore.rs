//! Start-up: rebuild scenes, clocks and body worlds from the snapshot and the log's tail.
//!
//! Order: the snapshot's admin part (scenes, clocks) and body worlds, then every record after
//! what the snapshot includes, in journal order. Body events step their world to the event's
//! tick on the scene's surface as it was at that point of the log, then apply. Finally each
//! body world is stepped to its scene clock's tick now: a server that never stopped would have
//! stepped there, so the restarted one continues the same trajectory.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use super::AppState;
use super::apply::Prepared;
use crate::bodies::SceneBodies;
use crate::bodies::event::MAX_REPLAY_STEPS;
use crate::journal::snapshot::append_body_events;
use crate::journal::{AdminScene, Op, Recovered};

/// Applies what [`crate::journal::Journal::open`] recovered to a state that holds the built-in and
/// configured scenes. Blocking (builds scenes, steps bodies).
pub fn restore(state: &AppState, rec: Recovered) {
    let snapshot = rec.snapshot.unwrap_or_default();
    // The snapshot's admin part, as the ops it folds: the last word on each scene, each clock,
    // then each scene's impacts in the order they were accepted.
    for (id, s) in &snapshot.admin.scenes {
        let op = match s {
            // The clock a put recorded is in `clocks`, applied below.
            AdminScene::Put(spec) => Op::ScenePut {
                scene: id.clone(),
                spec: spec.clone(),
                clock: None,
            },
            AdminScene::Deleted => Op::SceneDelete { scene: id.clone() },
        };
        state.apply(&op, Prepared::Nothing);
    }
    for (id, c) in &snapshot.admin.clocks {
        let op = Op::Clock {
            scene: id.clone(),
            clock: *c,
        };
        state.apply(&op, Prepared::Nothing);
    }
    for (id, list) in &snapshot.admin.impacts {
        for impact in list {
            let op = Op::Impact {
                scene: id.clone(),
                impact: *impact,
                body_tick: None,
            };
            state.apply(&op, Prepared::Nothing);
        }
    }
    let mut worlds: BTreeMap<String, SceneBodies> = BTreeMap::new();
    for (id, b) in &snapshot.bodies {
        match SceneBodies::from_world_record(&b.world) {
            Ok(w) => {
                worlds.insert(id.clone(), w);
            }
            Err(why) => tracing::error!(scene = %id, %why, "journal: skipping a body world"),
        }
    }
    let replayed = rec.records.len();
    for r in rec.records {
        let admin_new = r.seq > snapshot.admin_seq;
        if admin_new && r.op.is_admin() {
            state.apply(&r.op, Prepared::Nothing);
        }
        match &r.op {
            Op::SceneDelete { scene } if r.seq > snapshot.body_seq(scene) => {
                worlds.remove(scene);
            }
            Op::Body { scene, event } if r.seq > snapshot.body_seq(scene) => {
                if matches!(event, crate::bodies::BodyEvent::Created { .. }) {
                    match SceneBodies::from_created(event) {
                        Ok(w) => {
                            worlds.insert(scene.clone(), w);
                        }
                        Err(why) => {
                            tracing::error!(scene = %scene, %why, "journal: skipping a body world")
                        }
                    }
                    continue;
                }
                let (Some(w), Ok(entry)) = (worlds.get_mut(scene), state.scene(scene)) else {
                    continue; // The scene or its world is gone: nothing to apply it to.
                };
                w.replay(event, &entry.scene.surface);
            }
            _ => {}
        }
    }
    // Catch each world up with its clock, as a server that never stopped would have.
    let journal = state.journal();
    for (id, mut w) in worlds {
        let Ok(entry) = state.scene(&id) else {
            continue;
        };
        let target = state.read_clock(&entry).tick;
        let ahead = target - w.tick();
        let cap = catch_up_cap(state.limits.catch_up_max_s, entry.scene.spec.tick_hz);
        if ahead > 0 && ahead <= cap {
            catch_up(&mut w, &id, target, &entry.scene.surface);
        } else if ahead > crate::bodies::MAX_CATCH_UP_TICKS && !w.is_empty() {
            // (A shorter gap the body loop steps through itself, as after any stall.)
            tracing::info!(scene = %id, ticks = ahead, cap,
                "journal: the downtime is longer than limits.catch_up_max_s: the bodies re-anchor at the clock instead of catching up");
        }
        // (Further off or behind: the body loop re-anchors at its first step, and journals it.)
        if let Err(e) = append_body_events(journal, &id, &mut w) {
            tracing::error!(scene = %id, error = %e, "journal: could not record a re-anchor");
        }
        // The body impacts the snapshot held and the replay re-derived: the same set the
        // live server had (not announced: no frame carries restored impacts as new).
        w.sync_impacts(&entry.scene.impacts, false);
        tracing::info!(scene = %id, bodies = w.len(), tick = w.tick(), "bodies restored");
        state.bodies.insert(&id, w);
    }
    if replayed > 0 || !rec.problems.is_empty() {
        tracing::info!(replayed, problems = rec.problems.len(), "journal: restored");
    }
}

/// The most ticks a restored world of a scene ticking at `tick_hz` is stepped through at
/// start-up: `catch_up_max_s` (see [`crate::config::Limits::catch_up_max_s`]) in ticks, at most
/// [`MAX_REPLAY_STEPS`] (the replay's own limit, which every replica applies alike: it cannot be
/// a setting).
fn catch_up_cap(catch_up_max_s: u64, tick_hz: f64) -> i64 {
    let ticks = (catch_up_max_s as f64 * tick_hz).round();
    if ticks.is_finite() && ticks < MAX_REPLAY_STEPS as f64 {
        ticks.max(0.0) as i64
    } else {
        MAX_REPLAY_STEPS
    }
}

/// Ticks stepped between two progress checks while a restored world catches up (a second of
/// scene time at 30 Hz: a tick of one boat on an FFT scene costs ~15 ms in a replay, which
/// computes its own frames).
const CATCH_UP_CHUNK: i64 = 30;
/// A catch-up longer than this many ticks (30 s at 30 Hz) is announced and reported.
const CATCH_UP_REPORTED: i64 = 900;
/// How often a long catch-up logs its progress.
const CATCH_UP_LOG_EVERY: Duration = Duration::from_secs(5);

/// Steps a restored world to scene tick `target` (see the module docs), in chunks of
/// [`CATCH_UP_CHUNK`] ticks so that a long downtime logs its progress: an hour of ticks of many
/// bodies, or of one body on an FFT scene, takes minutes before the server is ready, and an
/// operator must be able to tell that from a hang. Chunks are the same fixed steps as one call
/// (stepping does not depend on how the ticks are grouped), so the trajectory is unchanged.
fn catch_up(w: &mut SceneBodies, id: &str, target: i64, surface: &swell_waves::Surface) {
    let (from, started) = (w.tick(), Instant::now());
    let total = target - from;
    let mut logged = started;
    if total > CATCH_UP_REPORTED {
        tracing::info!(scene = %id, ticks = total, bodies = w.len(),
            "journal: stepping the bodies through the downtime before serving (progress every 5 s)");
    }
    while w.tick() < target {
        let before = w.tick();
        w.step_to((before + CATCH_UP_CHUNK).min(target), surface);
        if w.tick() <= before {
            break; // A step failed (the model rejected the sea): the body loop takes over.
        }
        if logged.elapsed() >= CATCH_UP_LOG_EVERY {
            logged = Instant::now();
            let done = w.tick() - from;
            let rate = done as f64 / started.elapsed().as_secs_f64();
            tracing::info!(
                scene = %id,
                done,
                total,
                eta_s = ((target - w.tick()) as f64 / rate).round(),
                "journal: catching the bodies up"
            );
        }
    }
    if total > CATCH_UP_REPORTED {
        tracing::info!(scene = %id, ticks = total, seconds = started.elapsed().as_secs_f64(),
            "journal: bodies caught up");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_catch_up_cap_is_the_setting_in_ticks_within_the_replay_limit() {
        assert_eq!(catch_up_cap(3600, 30.0), MAX_REPLAY_STEPS);
        assert_eq!(catch_up_cap(60, 20.0), 1200);
        assert_eq!(catch_up_cap(0, 30.0), 0);
        assert_eq!(catch_up_cap(1, 0.5), 1);
        assert_eq!(catch_up_cap(u64::MAX, 30.0), MAX_REPLAY_STEPS);
        assert_eq!(catch_up_cap(7200, 30.0), MAX_REPLAY_STEPS);
    }

    /// The catch-up in chunks (with its progress log) steps the very ticks one `step_to` does:
    /// a restarted server still continues the never-stopped trajectory to the bit.
    #[test]
    fn catching_up_in_chunks_is_one_step_to() {
        let scene = crate::scene::builtin::built("lake");
        let mut a = SceneBodies::new(100, 30.0, 9.81).unwrap();
        let boat: crate::bodies::SpawnRequest = serde_json::from_value(serde_json::json!({
            "mass": 3000.0, "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
            "position": [0.0, 0.63, 0.0]}))
        .unwrap();
        a.spawn(&boat).unwrap();
        let mut b = SceneBodies::from_world_record(&a.world_record()).unwrap();
        let target = 100 + 2 * CATCH_UP_CHUNK + 7;
        a.step_to(target, &scene.surface);
        catch_up(&mut b, "lake", target, &scene.surface);
        assert_eq!(b.tick(), target);
        assert_eq!(
            serde_json::to_string(&a.states(None)).unwrap(),
            serde_json::to_string(&b.states(None)).unwrap()
        );
    }
}
