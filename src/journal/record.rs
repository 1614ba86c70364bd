//! The records of the journal and the snapshot, as JSON payloads.
//!
//! Every type here is serialised with serde's external tagging (`{"scene_put": {...}}`): numbers
//! go straight from serde_json's shortest round-trip writer to its exact (`float_roundtrip`)
//! parser, so a replayed f64 has the bits that were journaled.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::bodies::{BodyEvent, WorldRecord};
use crate::scene::store::ClockRecord;

/// One journal record: a sequence number (1, 2, …; never reused) and the change.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Position in the journal.
    pub seq: u64,
    /// The change.
    pub op: Op,
}

/// An acknowledged change.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Op {
    /// An admin put a scene (canonical spec JSON, defaults filled in).
    ScenePut {
        /// Scene id.
        scene: String,
        /// The spec.
        spec: Value,
        /// The scene's fresh clock, when the put moves the epoch of the scene it replaces:
        /// running from the new epoch, one generation after the replaced clock
        /// ([`crate::scene::Clock::restarted_from`]), read at the epoch (at the accepting
        /// process's now for an epoch still to come). Every replay and replica takes it as it
        /// is, as it takes an [`Op::Clock`]'s record.
        /// `None` when the put keeps the clock or creates the scene (generation 0); also in
        /// records written before puts carried one.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        clock: Option<ClockRecord>,
    },
    /// An admin deleted a scene (its clock and bodies go with it).
    SceneDelete {
        /// Scene id.
        scene: String,
    },
    /// An admin changed a scene's clock; the clock after the change.
    Clock {
        /// Scene id.
        scene: String,
        /// The clock.
        clock: ClockRecord,
    },
    /// A change to a scene's bodies.
    Body {
        /// Scene id.
        scene: String,
        /// The change.
        event: BodyEvent,
    },
    /// An impact was added to a scene ([`crate::impacts`]). Admin part: folded into
    /// [`AdminState::impacts`]; a later put or delete of the scene clears them.
    Impact {
        /// Scene id.
        scene: String,
        /// The impact.
        impact: swell_waves::particles::Impact,
        /// The scene tick the scene's bodies feel it from, where the writer knew it when it
        /// announced the impact: tick frames carry it ([`crate::impacts::ImpactEvent::body_tick`]).
        /// Never logged (`serde(skip)`): the body world's own log records that tick
        /// ([`BodyEvent::Impact`], a fleet body log's `impact` command), so a replay needs none.
        /// A local write applies it with the tick its body world just felt it at; a fleet's
        /// feed entry carries it beside the op (`body_tick`, set by the impact script).
        #[serde(skip)]
        body_tick: Option<i64>,
    },
}

impl Op {
    /// The scene the op changes.
    pub fn scene(&self) -> &str {
        match self {
            Op::ScenePut { scene, .. }
            | Op::SceneDelete { scene }
            | Op::Clock { scene, .. }
            | Op::Body { scene, .. }
            | Op::Impact { scene, .. } => scene,
        }
    }

    /// Whether the op is an admin change to scenes or clocks (the snapshot's `admin` part).
    pub fn is_admin(&self) -> bool {
        !matches!(self, Op::Body { .. })
    }
}

/// A scene as admins left it: put (with its spec) or deleted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AdminScene {
    /// Put with this spec.
    Put(Value),
    /// Deleted (a deleted built-in or configured scene stays deleted).
    Deleted,
}

/// What admins changed, folded: the last word on each scene and clock.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AdminState {
    /// Scenes put or deleted by an admin.
    pub scenes: BTreeMap<String, AdminScene>,
    /// Clocks set by an admin, or started afresh by a put that moved the scene's epoch.
    pub clocks: BTreeMap<String, ClockRecord>,
    /// Impacts added since each scene's last put, in the order they were accepted (absent in
    /// snapshots written before impacts existed).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub impacts: BTreeMap<String, Vec<swell_waves::particles::Impact>>,
}

impl AdminState {
    /// Folds in one op (body ops are ignored).
    pub fn apply(&mut self, op: &Op) {
        match op {
            Op::ScenePut { scene, spec, clock } => {
                self.scenes
                    .insert(scene.clone(), AdminScene::Put(spec.clone()));
                // A put that moved the epoch replaced the clock: the replaced one's record
                // must not outlive it (a restore would bring the old clock back).
                if let Some(c) = clock {
                    self.clocks.insert(scene.clone(), *c);
                }
                self.impacts.remove(scene);
            }
            Op::SceneDelete { scene } => {
                self.scenes.insert(scene.clone(), AdminScene::Deleted);
                self.clocks.remove(scene);
                self.impacts.remove(scene);
            }
            Op::Impact { scene, impact, .. } => {
                self.impacts.entry(scene.clone()).or_default().push(*impact);
            }
            Op::Clock { scene, clock } => {
                self.clocks.insert(scene.clone(), *clock);
            }
            Op::Body { .. } => {}
        }
    }
}

/// One scene's body world in a snapshot, and the journal position it includes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodiesSnapshot {
    /// Every body record of this scene with `seq <= seq` is already in `world`.
    pub seq: u64,
    /// The world.
    pub world: WorldRecord,
}

/// The state the journal's records build up to, as of known journal positions. Replay starts
/// from it and applies only the records after those positions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Wall-clock time it was taken, Unix seconds (for people).
    pub unix: f64,
    /// Every admin record with `seq <= admin_seq` is in `admin`.
    pub admin_seq: u64,
    /// Scenes and clocks as admins left them.
    pub admin: AdminState,
    /// Scenes without an entry in `bodies` had no body world at `bodies_seq`: their body
    /// records with `seq <= bodies_seq` are obsolete.
    pub bodies_seq: u64,
    /// Body worlds by scene.
    pub bodies: BTreeMap<String, BodiesSnapshot>,
}

impl Snapshot {
    /// The last record already included for `op` (so replay skips records up to it).
    pub fn covers(&self, op: &Op) -> u64 {
        match op {
            Op::Body { scene, .. } => self.body_seq(scene),
            _ => self.admin_seq,
        }
    }

    /// The last body record of `scene` already included.
    pub fn body_seq(&self, scene: &str) -> u64 {
        self.bodies.get(scene).map_or(self.bodies_seq, |b| b.seq)
    }

    /// The last record every part includes: records up to it may be dropped from the log.
    pub fn cut(&self) -> u64 {
        self.bodies
            .values()
            .map(|b| b.seq)
            .fold(self.admin_seq.min(self.bodies_seq), u64::min)
    }

    /// The highest journal position it mentions.
    pub fn max_seq(&self) -> u64 {
        self.bodies
            .values()
            .map(|b| b.seq)
            .fold(self.admin_seq.max(self.bodies_seq), u64::max)
    }
}
