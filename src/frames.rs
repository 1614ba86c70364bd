//! The shared FFT frame cache.
//!
//! An FFT frame (the grids of one FFT layer at one time) costs one inverse 2-D FFT per field and
//! is the same for every request that reads it, so it is computed once and shared. With the
//! model's default time sampling ([`TimeSampling::Grid`]) a query at any t reads the frames of
//! the one or two grid times around t, so every query between the same two grid times — in
//! particular every query at the scene's *now* — shares the same frames; entries are keyed by
//! grid index. Queries with `accuracy.time = "exact"` key their frame by the bits of t.
//!
//! Entries are keyed by `(source, layer, grid index or t)`; each holds a `OnceLock`, so requests
//! that arrive together while a frame is being computed wait for that one computation instead of
//! repeating it. An entry holds the fields it was computed with; a request needing more replaces
//! it with a frame of the union.
//!
//! # Scenes with equal seas share frames
//! A frame is a pure function of the surface spec, the layer, the time and the fields, so the
//! *source* of an entry is the surface spec, not the scene: scenes built from equal surface specs
//! (the same JSON, number for number: twenty matches started from one preset) read one set of
//! frames, computed once. Clocks started from the same epoch read the same grid frames at now;
//! scenes whose clocks differ share whatever times they have in common. A source lives while a
//! scene built from it does ([`FrameCache::forget_scene`]).
//!
//! # Two pools: near now, and everything else
//! A grid frame within [`NEAR_STEPS`] grid steps of the scene's clock *now* is a **near** frame;
//! every other frame (far-off times, exact times) is a **far** frame. Far frames live in a
//! least-recently-used pool of `capacity` entries and evict only each other, so a client asking
//! for many distant times cannot evict the frames every player at *now* reads. Near frames are
//! dropped when the clock has left them behind (more than [`NEAR_STEPS`] steps away) or when
//! unused for [`NEAR_IDLE`], so they are bounded by `2·NEAR_STEPS + 1` per FFT layer of each
//! scene in use.
//!
//! # Computing ahead
//! While a scene is queried near its clock's now ([`FrameCache::active_scenes`]: a query or a
//! body step reading a near grid frame within [`ACTIVE_FOR`]), [`run_ahead`](crate::state::ahead::run_ahead) computes the grid
//! frames the clock is about to reach, so a query at now finds its frames ready and answers
//! without waiting for an FFT (on the reactor, see `service::query`). Queries at far-off or
//! exact times alone do not start it: those frames would be of no use to them.
//!
//! Frames ahead get the fields the scene's queries asked for within the last [`ACTIVE_FOR`] to
//! 2·[`ACTIVE_FOR`] (height, at least), not every field ever asked: one normal query does not
//! make every later frame pay for slopes (2 of a frame's 8 transforms). A query needing a field
//! the frames ahead lack widens its frame on demand, with the same bits.
//!
//! A scene's body loop also computes ahead ([`FrameCache::compute_through`]), right after each
//! step, through the next tick boundary and two grid steps past it: the frames its next step
//! reads and those the ahead loop would otherwise find due at that boundary, where they would
//! run beside the next step.
//!
//! Computing happens in the caller's thread, which must be a blocking one (`spawn_blocking`):
//! `OnceLock::get_or_init` blocks the waiters.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use swell_waves::fft::{FftFields, FftFrame, FftLayer};
use swell_waves::{
    Layer, LayerFrames, QueryFields, QueryOptions, SpecError, SurfaceAt, TimeSampling,
};

use crate::scene::Scene;

/// Grid steps either side of the clock's now whose frames are protected from far-off requests:
/// 6 steps (100 ms at the default 1/60 s) covers clients whose own synchronised clocks, or
/// request latency, put their `t` a little before or after the server's now.
pub const NEAR_STEPS: u64 = 6;

/// A near frame unused this long is dropped (its scene has gone quiet, or been replaced).
pub const NEAR_IDLE: Duration = Duration::from_secs(5);

/// A scene counts as in use (its frames are computed ahead) this long after its last query.
pub const ACTIVE_FOR: Duration = Duration::from_secs(2);

/// Which frame of a layer an entry holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum When {
    /// Grid index.
    Grid(u64),
    /// The bits of an exact query time.
    Exact(u64),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Key {
    /// The frames' source ([`Inner::source`]): one per distinct surface spec in use, so scenes
    /// built from equal specs share frames and a scene whose spec changed never reads the old
    /// ones.
    source: u64,
    layer: usize,
    when: When,
}

type Slot = Arc<OnceLock<Arc<FftFrame>>>;

#[derive(Debug)]
struct Entry {
    slot: Slot,
    fields: FftFields,
    /// The scenes ([`Scene::uid`]) for which this is a near frame (within [`NEAR_STEPS`] of
    /// their clock's now when they read it): empty for a far frame. A frame shared by scenes
    /// whose clocks differ stays near while it is near for one of them.
    near: Vec<u64>,
    used: u64,
    used_at: Instant,
}

impl Entry {
    fn is_near(&self) -> bool {
        !self.near.is_empty()
    }
}

type PerLayer = [FftFields; swell_waves::surface::MAX_LAYERS];

/// What the cache knows of a scene's recent queries.
#[derive(Debug, Clone, Copy)]
struct Activity {
    last: Instant,
    /// Union of the FFT fields queries needed since `since`, per layer.
    wanted: PerLayer,
    /// The same union over the [`ACTIVE_FOR`] before `since`.
    before: PerLayer,
    since: Instant,
}

impl Activity {
    fn new(now: Instant) -> Activity {
        Activity {
            last: now,
            wanted: [FftFields::NONE; swell_waves::surface::MAX_LAYERS],
            before: [FftFields::NONE; swell_waves::surface::MAX_LAYERS],
            since: now,
        }
    }

    /// Starts a new window when the current one is [`ACTIVE_FOR`] old, so a field nobody asked
    /// for in the last 2·[`ACTIVE_FOR`] is no longer wanted.
    fn roll(&mut self, now: Instant) {
        let age = now.saturating_duration_since(self.since);
        if age >= ACTIVE_FOR {
            self.before = if age >= 2 * ACTIVE_FOR {
                [FftFields::NONE; swell_waves::surface::MAX_LAYERS]
            } else {
                self.wanted
            };
            self.wanted = [FftFields::NONE; swell_waves::surface::MAX_LAYERS];
            self.since = now;
        }
    }

    /// The fields of layer `i` queries asked for within the last [`ACTIVE_FOR`] to
    /// 2·[`ACTIVE_FOR`].
    fn wanted(&self, i: usize) -> FftFields {
        self.wanted[i].union(self.before[i])
    }
}

/// A source of frames: the scenes built from one surface spec.
#[derive(Debug)]
struct Source {
    id: u64,
    /// Scenes ([`Scene::uid`]) reading this source and not forgotten.
    scenes: Vec<u64>,
}

#[derive(Debug, Default)]
struct Inner {
    entries: HashMap<Key, Entry>,
    activity: HashMap<u64, Activity>,
    /// Sources by the JSON of their surface spec (serde_json writes every f64 in its shortest
    /// round-trip form, so equal text means equal bits, and so bit-identical frames).
    sources: HashMap<String, Source>,
    /// Each scene's source id ([`Inner::source`]).
    scene_source: HashMap<u64, u64>,
    next_source: u64,
    /// 2-D inverse transforms computed (one per grid of each frame): what the cache costs.
    transforms: u64,
    /// Frames computed, by [`ComputedBy`].
    computed: [u64; 4],
    clock: u64,
    far: usize,
    /// Scenes deleted or replaced ([`FrameCache::forget_scene`]), the newest
    /// [`RETIRED_KEPT`]: a query or the ahead loop that still holds such a scene computes its
    /// frame without caching it, so nothing re-fills the cache after the forget.
    retired: std::collections::HashSet<u64>,
    retired_order: std::collections::VecDeque<u64>,
}

impl Inner {
    /// The source of `scene`'s frames, registering the scene on first sight; `None` for a scene
    /// forgotten meanwhile (its frames are computed for the caller alone).
    fn source(&mut self, scene: &Scene) -> Option<u64> {
        if let Some(&id) = self.scene_source.get(&scene.uid) {
            return Some(id);
        }
        if self.retired.contains(&scene.uid) {
            return None;
        }
        // Once per scene: the spec's JSON (microseconds), then a map lookup per query. Plain
        // data serialises without error; an empty text would only keep the scene from sharing.
        let text = serde_json::to_string(&scene.spec.surface).unwrap_or_default();
        let next = &mut self.next_source;
        let source = self.sources.entry(text).or_insert_with(|| {
            *next += 1;
            Source {
                id: *next,
                scenes: Vec::new(),
            }
        });
        source.scenes.push(scene.uid);
        let id = source.id;
        self.scene_source.insert(scene.uid, id);
        Some(id)
    }
}

/// Retired scene uids remembered. A query holds its scene for milliseconds; by the time
/// thousands of scenes have been retired since, no request still holds this one.
const RETIRED_KEPT: usize = 4096;

/// A bounded cache of FFT frames shared by all requests.
#[derive(Debug)]
pub struct FrameCache {
    capacity: usize,
    inner: Mutex<Inner>,
}

/// Circular distance between two grid indices of a grid of `m` steps.
fn grid_distance(a: u64, b: u64, m: u64) -> u64 {
    let d = a.abs_diff(b) % m;
    d.min(m - d)
}

impl FrameCache {
    /// A cache holding at most `capacity` far frames (at least 1), plus the near frames.
    pub fn new(capacity: usize) -> FrameCache {
        FrameCache {
            capacity: capacity.max(1),
            inner: Mutex::new(Inner::default()),
        }
    }

    /// Drops every frame of the built scene `uid` (deleted or replaced): its memory goes at
    /// once, not when the frames would have aged out.
    pub fn forget_scene(&self, uid: u64) {
        let mut g = self.lock();
        if g.retired.insert(uid) {
            g.retired_order.push_back(uid);
            if g.retired_order.len() > RETIRED_KEPT
                && let Some(old) = g.retired_order.pop_front()
            {
                g.retired.remove(&old);
            }
        }
        g.activity.remove(&uid);
        let Some(source) = g.scene_source.remove(&uid) else {
            return;
        };
        // The source's last scene takes its frames with it; otherwise the frames stay for the
        // scenes still reading them, less those near only for this one.
        let mut last = false;
        g.sources.retain(|_, s| {
            if s.id == source {
                s.scenes.retain(|&u| u != uid);
                last = s.scenes.is_empty();
            }
            !(s.id == source && last)
        });
        let mut far_dropped = 0;
        g.entries.retain(|k, e| {
            if k.source != source {
                return true;
            }
            let was_near = e.is_near();
            e.near.retain(|&u| u != uid);
            let keep = !last && (!was_near || e.is_near());
            if !keep && !was_near {
                far_dropped += 1;
            }
            keep
        });
        g.far -= far_dropped;
    }

    /// The FFT memory a scene in use holds at most, bytes: the near frames of each FFT layer
    /// (`2·NEAR_STEPS + 1` frames of every field, `resolution²` f64 values each) and the
    /// layer's spectrum (h0 and ω, complex and real, per mode). What `max_fft_bytes` is
    /// charged when the scene is put.
    pub fn scene_bytes(scene: &Scene) -> u64 {
        scene
            .surface
            .layers()
            .iter()
            .map(|layer| match layer {
                Layer::Fft(f) => {
                    let cells = (f.resolution() * f.resolution()) as u64;
                    let frame = cells * FftFields::ALL.grid_count() as u64 * 8;
                    (2 * NEAR_STEPS + 1) * frame + cells * (16 + 8)
                }
                _ => 0,
            })
            .sum()
    }

    /// Number of frames held (computed or being computed), near and far.
    pub fn len(&self) -> usize {
        self.lock().entries.len()
    }

    /// Whether the cache is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of near frames held.
    pub fn near_len(&self) -> usize {
        self.lock().entries.values().filter(|e| e.is_near()).count()
    }

    /// Frames computed so far by `by` (what `swell_fft_frames_total{by}` counts).
    pub fn computed(&self, by: ComputedBy) -> u64 {
        self.lock().computed[by.index()]
    }

    /// 2-D inverse transforms computed so far (one per grid of each frame, see
    /// [`FftFields::grid_count`]): the work the cache has cost.
    pub fn transforms(&self) -> u64 {
        self.lock().transforms
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic while holding this lock cannot leave the map inconsistent (each operation is a
        // single insert/remove), so a poisoned lock is still usable.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The frame times one layer reads at `t`: one or two keys.
    fn whens(layer: &FftLayer, t: f64, time: TimeSampling) -> (When, Option<When>) {
        match time {
            TimeSampling::Exact => (When::Exact(t.to_bits()), None),
            TimeSampling::Grid => {
                let p = layer.grid_position(t);
                (
                    When::Grid(p.index),
                    (p.weight > 0.0).then_some(When::Grid(p.next)),
                )
            }
        }
    }

    /// Whether `when` is a near frame of `layer` given the clock's `now`.
    fn is_near(layer: &FftLayer, when: When, now: f64) -> bool {
        match when {
            When::Exact(_) => false,
            When::Grid(n) => {
                let at = layer.grid_position(now).index;
                grid_distance(n, at, layer.grid_steps()) <= NEAR_STEPS
            }
        }
    }

    /// Whether a query of `scene` at `t` reads a near frame of any FFT layer: a grid frame
    /// within [`NEAR_STEPS`] of the clock's `now`.
    fn reads_near(scene: &Scene, t: f64, now: f64, time: TimeSampling) -> bool {
        scene.surface.layers().iter().any(|layer| match layer {
            Layer::Fft(f) => Self::is_near(f, Self::whens(f, t, time).0, now),
            _ => false,
        })
    }

    /// Notes a query of `scene` needing `need` from each FFT layer.
    fn note_activity(g: &mut Inner, scene: &Scene, need: &[FftFields]) {
        let now = Instant::now();
        let a = g
            .activity
            .entry(scene.uid)
            .or_insert_with(|| Activity::new(now));
        a.last = now;
        a.roll(now);
        for (w, n) in a.wanted.iter_mut().zip(need) {
            *w = w.union(*n);
        }
    }

    /// The slot holding `key` with at least `need`, creating (or widening) it if absent, and
    /// evicting as the pools require.
    fn slot(
        &self,
        scene: &Scene,
        at: (usize, When),
        need: FftFields,
        near: bool,
    ) -> (Slot, FftFields) {
        let mut guard = self.lock();
        let g = &mut *guard;
        let Some(source) = g.source(scene) else {
            // A scene deleted meanwhile: its frame is computed for this caller alone.
            return (Arc::new(OnceLock::new()), need);
        };
        let key = Key {
            source,
            layer: at.0,
            when: at.1,
        };
        let uid = scene.uid;
        g.clock += 1;
        let stamp = g.clock;
        let now = Instant::now();
        if let Some(e) = g.entries.get_mut(&key)
            && e.fields.contains(need)
        {
            e.used = stamp;
            e.used_at = now;
            if near && !e.near.contains(&uid) {
                // A far frame the clock has come close to joins the near pool.
                if e.near.is_empty() {
                    g.far -= 1;
                }
                e.near.push(uid);
            }
            return (e.slot.clone(), e.fields);
        }
        // Absent, or too few fields: a new slot with the union (waiters on an old slot still
        // get the frame they asked for), near for the scenes the old one was near for.
        let fields = g.entries.get(&key).map_or(need, |e| e.fields.union(need));
        let mut near_for = Vec::new();
        if let Some(old) = g.entries.remove(&key) {
            if !old.is_near() {
                g.far -= 1;
            }
            near_for = old.near;
        }
        if near && !near_for.contains(&uid) {
            near_for.push(uid);
        }
        if !near_for.is_empty() {
            // Near frames the clock has left behind or nobody reads go first.
            g.entries
                .retain(|_, e| !e.is_near() || now.duration_since(e.used_at) < NEAR_IDLE);
        } else {
            while g.far >= self.capacity {
                let oldest = g
                    .entries
                    .iter()
                    .filter(|(_, e)| !e.is_near())
                    .min_by_key(|(_, e)| e.used)
                    .map(|(k, _)| *k);
                match oldest {
                    Some(k) => {
                        g.entries.remove(&k);
                        g.far -= 1;
                    }
                    None => break,
                }
            }
            g.far += 1;
        }
        let slot: Slot = Arc::new(OnceLock::new());
        g.entries.insert(
            key,
            Entry {
                slot: slot.clone(),
                fields,
                near: near_for,
                used: stamp,
                used_at: now,
            },
        );
        (slot, fields)
    }

    /// Drops near frames of `scene` that are now more than [`NEAR_STEPS`] from the clock.
    /// A frame shared with other scenes stays while it is near for one of them.
    fn prune_near(&self, scene: &Scene, now: f64) {
        let mut g = self.lock();
        let Some(&source) = g.scene_source.get(&scene.uid) else {
            return;
        };
        g.entries.retain(|k, e| {
            if k.source != source || !e.near.contains(&scene.uid) {
                return true;
            }
            let near = match scene.surface.layers().get(k.layer) {
                Some(Layer::Fft(f)) => Self::is_near(f, k.when, now),
                _ => false,
            };
            if !near {
                e.near.retain(|&u| u != scene.uid);
            }
            e.is_near()
        });
    }

    /// One frame of `layer` (index `i` of `scene`'s layers) at `when`, from the cache or
    /// computed now for `caller` (and counted, see [`ComputedBy`]).
    fn frame(
        &self,
        scene: &Scene,
        (i, layer): (usize, &FftLayer),
        when: When,
        need: FftFields,
        now: f64,
        caller: Caller,
    ) -> Arc<FftFrame> {
        let near = Self::is_near(layer, when, now);
        let by = match caller {
            Caller::Ahead => ComputedBy::Ahead,
            Caller::Bodies => ComputedBy::Bodies,
            Caller::Query if near => ComputedBy::QueryNear,
            Caller::Query => ComputedBy::QueryFar,
        };
        let (slot, fields) = self.slot(scene, (i, when), need, near);
        slot.get_or_init(|| {
            let start = Instant::now();
            let frame = Arc::new(match when {
                When::Grid(n) => layer.grid_frame(n, fields),
                When::Exact(bits) => layer.frame(f64::from_bits(bits), fields),
            });
            {
                let mut g = self.lock();
                g.transforms += frame.transforms() as u64;
                g.computed[by.index()] += 1;
            }
            metrics::counter!("swell_fft_frames_total", "by" => by.label()).increment(1);
            metrics::histogram!("swell_fft_frame_seconds").record(start.elapsed().as_secs_f64());
            frame
        })
        .clone()
    }

    /// The FFT fields queries of `fields` need from every layer.
    fn needs(scene: &Scene, fields: QueryFields) -> Vec<FftFields> {
        scene
            .surface
            .layers()
            .iter()
            .map(|l| match l {
                Layer::Fft(f) => scene.surface.fft_fields_for(f, fields),
                _ => FftFields::NONE,
            })
            .collect()
    }

    /// The scene's surface at `t`, ready for queries of `fields` with `options`, with every FFT
    /// frame taken from (or computed into) the cache; `now` is the scene clock's time now (it
    /// decides which frames are near). Blocking when a frame must be computed: call from
    /// `spawn_blocking` unless [`FrameCache::has_frames`] said yes.
    ///
    /// # Errors
    /// `t` not finite or invalid `options` (the model's error).
    pub fn surface_at<'s>(
        &self,
        scene: &'s Scene,
        t: f64,
        now: f64,
        fields: QueryFields,
        options: &QueryOptions,
    ) -> Result<SurfaceAt<'s>, SpecError> {
        scene
            .impacts
            .apply(self.frames_at_by(scene, t, now, fields, options, Caller::Query))
    }

    /// [`FrameCache::surface_at`] without the scene's impacts: the surface of the spec alone,
    /// exactly what `scene.surface.at(t, fields, options)` gives, its FFT frames shared. The
    /// body loop steps on it (a body's sea is its scene's surface; see `bodies`).
    ///
    /// # Errors
    /// As [`FrameCache::surface_at`].
    pub fn frames_at<'s>(
        &self,
        scene: &'s Scene,
        t: f64,
        now: f64,
        fields: QueryFields,
        options: &QueryOptions,
    ) -> Result<SurfaceAt<'s>, SpecError> {
        self.frames_at_by(scene, t, now, fields, options, Caller::Bodies)
    }

    /// [`FrameCache::frames_at`] for `caller`.
    fn frames_at_by<'s>(
        &self,
        scene: &'s Scene,
        t: f64,
        now: f64,
        fields: QueryFields,
        options: &QueryOptions,
        caller: Caller,
    ) -> Result<SurfaceAt<'s>, SpecError> {
        let surface = &scene.surface;
        if !surface.has_fft() || options.reference {
            return surface.at(t, fields, options);
        }
        // Check before computing anything: a bad t or option must not cost a frame.
        if !t.is_finite() {
            return surface.at_with_frames(t, Vec::new(), options);
        }
        options.validate()?;
        let needs = Self::needs(scene, fields);
        // Only a query near the clock's now keeps the scene's frames computed ahead: the frames
        // the clock reaches next are of no use to one at a far-off (or exact) time, and
        // computing them costs ~15% of a core per FFT scene (60 frames a second).
        if Self::reads_near(scene, t, now, options.time) {
            Self::note_activity(&mut self.lock(), scene, &needs);
        }
        let frames = surface
            .layers()
            .iter()
            .enumerate()
            .map(|(i, layer)| match layer {
                Layer::Fft(f) => {
                    let (a, b) = Self::whens(f, t, options.time);
                    let frame = self.frame(scene, (i, f), a, needs[i], now, caller);
                    let next = b.map(|b| self.frame(scene, (i, f), b, needs[i], now, caller));
                    Some(LayerFrames { frame, next })
                }
                _ => None,
            })
            .collect();
        surface.at_with_frames(t, frames, options)
    }

    /// Whether [`FrameCache::surface_at`] would find every frame it needs already computed
    /// (always true without FFT layers): then it costs microseconds and cannot block.
    pub fn has_frames(
        &self,
        scene: &Scene,
        t: f64,
        fields: QueryFields,
        options: &QueryOptions,
    ) -> bool {
        if !scene.surface.has_fft() {
            return true;
        }
        if !t.is_finite() || options.reference {
            return false;
        }
        let needs = Self::needs(scene, fields);
        let g = self.lock();
        let Some(&source) = g.scene_source.get(&scene.uid) else {
            return false;
        };
        scene
            .surface
            .layers()
            .iter()
            .enumerate()
            .all(|(i, layer)| match layer {
                Layer::Fft(f) => {
                    let (a, b) = Self::whens(f, t, options.time);
                    [Some(a), b].into_iter().flatten().all(|when| {
                        let key = Key {
                            source,
                            layer: i,
                            when,
                        };
                        g.entries
                            .get(&key)
                            .is_some_and(|e| e.fields.contains(needs[i]) && e.slot.get().is_some())
                    })
                }
                _ => true,
            })
    }

    /// Uids of the scenes queried near their clock's now within [`ACTIVE_FOR`].
    pub fn active_scenes(&self) -> Vec<u64> {
        let now = Instant::now();
        let mut g = self.lock();
        g.activity
            .retain(|_, a| now.duration_since(a.last) < ACTIVE_FOR);
        g.activity.keys().copied().collect()
    }

    /// Computes the grid frames the clock reaches next: those read at `now` and one and two
    /// grid steps later in the clock's direction (`rate` scene seconds per second; paused: 0),
    /// with the fields recent queries wanted (height, at least). Frames already held cost
    /// nothing. Blocking: call from `spawn_blocking`. Returns the number of frames computed.
    pub fn compute_ahead(&self, scene: &Scene, now: f64, rate: f64) -> usize {
        self.compute(scene, now, rate, 0.0, Caller::Ahead)
    }

    /// [`FrameCache::compute_ahead`] reaching `lead` scene seconds further: every grid frame a
    /// read between `now` and `lead` + [`AHEAD_STEPS`] grid steps later in the clock's direction
    /// needs (at most [`MAX_AHEAD_STEPS`] grid steps in all). The body loop calls it right after
    /// its step with a tick period as `lead`, so the frames its next step and the ahead loop
    /// at the next tick boundary want are computed on the step's own thread after the states
    /// went out, not at that boundary beside the next step.
    pub fn compute_through(&self, scene: &Scene, now: f64, rate: f64, lead: f64) -> usize {
        self.compute(scene, now, rate, lead, Caller::Bodies)
    }

    /// The frames [`FrameCache::plan_through`] finds missing, computed for `caller`.
    fn compute(&self, scene: &Scene, now: f64, rate: f64, lead: f64, caller: Caller) -> usize {
        let due = self.plan_through(scene, now, rate, lead);
        for &(i, when, need) in &due {
            if let Some(Layer::Fft(f)) = scene.surface.layers().get(i) {
                self.frame(scene, (i, f), when, need, now, caller);
            }
        }
        due.len()
    }

    /// Whether [`FrameCache::compute_ahead`] has a frame to compute for `scene` at `now`, doing
    /// at once the rest of its work, which needs no FFT: near frames the clock has left behind
    /// are dropped, and frames ahead that are already held (another scene of the same sea
    /// computed them) are marked near for this scene. Cheap (one pass over the cache under its
    /// lock): the ahead loop asks it on the reactor for every scene in use, every
    /// [`AHEAD_PERIOD`], and hands the blocking pool only the scenes that have a frame due.
    pub fn ahead_due(&self, scene: &Scene, now: f64, rate: f64) -> bool {
        !self.plan_through(scene, now, rate, 0.0).is_empty()
    }

    /// The frames [`FrameCache::compute_through`] must compute, `(layer index, when, fields)`,
    /// after dropping `scene`'s near frames the clock has left behind and marking the held
    /// frames ahead near for `scene`. Computes nothing.
    fn plan_through(&self, scene: &Scene, now: f64, rate: f64, lead: f64) -> Vec<Due> {
        let wanted = self.lock().activity.get_mut(&scene.uid).map(|a| {
            a.roll(Instant::now());
            *a
        });
        self.prune_near(scene, now);
        // f64::signum(0.0) is 1: a paused clock stays where it is.
        let direction = if rate > 0.0 {
            1.0
        } else if rate < 0.0 {
            -1.0
        } else {
            0.0
        };
        let mut ahead: Vec<(Due, bool)> = Vec::new();
        for (i, layer) in scene.surface.layers().iter().enumerate() {
            let Layer::Fft(f) = layer else { continue };
            let need = wanted.map_or(FftFields::HEIGHT, |w| w.wanted(i).union(FftFields::HEIGHT));
            let step = f.time_step() * direction;
            // `max` drops a NaN lead; the layer's time step is positive (validated).
            let steps = (AHEAD_STEPS + lead.max(0.0) / f.time_step()).min(MAX_AHEAD_STEPS);
            // Grid times up to `steps` (and the reach itself: it may fall between two).
            let reads = (0..=steps.ceil() as u32).map(|k| f64::from(k).min(steps));
            for k in reads {
                let (a, b) = Self::whens(f, now + step * k, TimeSampling::Grid);
                for w in [Some(a), b].into_iter().flatten() {
                    if !ahead.iter().any(|((l, x, _), _)| *l == i && *x == w) {
                        ahead.push(((i, w, need), Self::is_near(f, w, now)));
                    }
                }
            }
        }
        let mut guard = self.lock();
        let g = &mut *guard;
        let Some(source) = g.source(scene) else {
            // A scene forgotten meanwhile: nothing is held for it.
            return ahead.into_iter().map(|(due, _)| due).collect();
        };
        let uid = scene.uid;
        let mut due = Vec::new();
        for ((layer, when, need), near) in ahead {
            let key = Key {
                source,
                layer,
                when,
            };
            match g.entries.get_mut(&key) {
                Some(e) if e.fields.contains(need) => {
                    // Held (another scene of the same sea computed it): near for this one
                    // too, so it stays while this clock needs it.
                    if near && !e.near.contains(&uid) {
                        if e.near.is_empty() {
                            g.far -= 1;
                        }
                        e.near.push(uid);
                    }
                }
                _ => due.push((layer, when, need)),
            }
        }
        due
    }
}

/// A frame to compute: layer index, grid time, fields.
type Due = (usize, When, FftFields);

/// Who asks [`FrameCache::frame`] for a frame.
#[derive(Debug, Clone, Copy)]
enum Caller {
    Ahead,
    Bodies,
    Query,
}

/// Who computed a frame: the `by` label of `swell_fft_frames_total`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ComputedBy {
    /// The frame-ahead loop ([`FrameCache::compute_ahead`]).
    Ahead,
    /// The body loop: its reach past each step ([`FrameCache::compute_through`]) or a frame its
    /// step found missing ([`FrameCache::frames_at`]).
    Bodies,
    /// A query, for a frame near its scene's now: the ahead loop had not computed it (it is not
    /// keeping up, or the scene had just become active). Growing steadily, this says the
    /// server is out of FFT capacity for the scenes in use.
    QueryNear,
    /// A query, for a frame at a far-off or exact time: no loop computes those.
    QueryFar,
}

impl ComputedBy {
    /// Every value, in declaration order.
    pub const ALL: [ComputedBy; 4] = [
        ComputedBy::Ahead,
        ComputedBy::Bodies,
        ComputedBy::QueryNear,
        ComputedBy::QueryFar,
    ];

    /// The metric label.
    pub fn label(self) -> &'static str {
        match self {
            ComputedBy::Ahead => "ahead",
            ComputedBy::Bodies => "bodies",
            ComputedBy::QueryNear => "query_near",
            ComputedBy::QueryFar => "query_far",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// Grid steps past the clock's now whose frames [`FrameCache::compute_ahead`] prepares.
pub const AHEAD_STEPS: f64 = 2.0;

/// Most grid steps [`FrameCache::compute_through`] reaches past now: near frames are those
/// within [`NEAR_STEPS`] of now; it stops short of them.
pub const MAX_AHEAD_STEPS: f64 = NEAR_STEPS as f64 - 1.0;

/// How often [`run_ahead`](crate::state::ahead::run_ahead) looks at the clocks: well inside one grid step (17 ms by default),
/// so the next frames are ready long before the clock reaches them.
pub const AHEAD_PERIOD: Duration = Duration::from_millis(5);

#[cfg(test)]
mod tests {
    use super::*;

    use crate::scene::builtin::built as builtin;

    fn fft(scene: &Scene) -> &FftLayer {
        match &scene.surface.layers()[0] {
            Layer::Fft(f) => f,
            _ => panic!("layer 0 is FFT"),
        }
    }

    #[test]
    fn grid_distance_wraps() {
        assert_eq!(grid_distance(0, 5999, 6000), 1);
        assert_eq!(grid_distance(10, 13, 6000), 3);
        assert_eq!(grid_distance(13, 10, 6000), 3);
        assert_eq!(grid_distance(0, 3000, 6000), 3000);
    }

    /// The cache's promise: any number of far-off times cannot evict the frames around the
    /// clock's now, which every query at now reads.
    #[test]
    fn far_off_times_cannot_evict_the_frames_around_now() {
        let scene = builtin("storm");
        let cache = FrameCache::new(2);
        let o = QueryOptions::default();
        let now = 100.01;
        let f = fft(&scene);
        let p = f.grid_position(now);
        cache
            .surface_at(&scene, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        assert!(cache.has_frames(&scene, now, QueryFields::HEIGHT, &o));
        assert_eq!(cache.near_len(), 2, "frames {} and {}", p.index, p.next);
        // Far-off times, more than the far pool holds.
        for k in 0..6 {
            let t = 5.0 + 7.3 * f64::from(k);
            cache
                .surface_at(&scene, t, now, QueryFields::HEIGHT, &o)
                .unwrap();
        }
        assert!(
            cache.has_frames(&scene, now, QueryFields::HEIGHT, &o),
            "the frames at now were evicted"
        );
        assert_eq!(cache.near_len(), 2);
        assert!(cache.len() <= 2 + 2, "far pool bounded: {}", cache.len());
        // An exact time is a far frame too.
        let exact = QueryOptions {
            time: TimeSampling::Exact,
            ..o
        };
        cache
            .surface_at(&scene, now, now, QueryFields::HEIGHT, &exact)
            .unwrap();
        assert!(cache.has_frames(&scene, now, QueryFields::HEIGHT, &o));
    }

    /// Every query between the same two grid times reads the same two frames: one computation.
    #[test]
    fn queries_between_two_grid_times_share_their_frames() {
        let scene = builtin("open-sea");
        let cache = FrameCache::new(8);
        let o = QueryOptions::default();
        let f = fft(&scene);
        let t0 = f.grid_time(3000);
        for k in 1..10 {
            let t = t0 + f.time_step() * f64::from(k) / 10.0;
            cache
                .surface_at(&scene, t, t, QueryFields::HEIGHT, &o)
                .unwrap();
        }
        assert_eq!(cache.len(), 2);
        // A query needing more fields widens the frames in place.
        let dt = f.time_step();
        cache
            .surface_at(&scene, t0 + 0.3 * dt, t0, QueryFields::ALL, &o)
            .unwrap();
        assert_eq!(cache.len(), 2);
        assert!(cache.has_frames(&scene, t0 + 0.6 * dt, QueryFields::ALL, &o));
    }

    /// Only queries near the clock's now make a scene active (its frames computed ahead): one
    /// at a far-off grid time, or at an exact time, gains nothing from the frames the clock
    /// reaches next.
    #[test]
    fn only_queries_near_now_make_a_scene_active() {
        let scene = builtin("storm");
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&scene);
        let now = f.grid_time(500) + 0.25 * f.time_step();
        let far = now + 3.0 * NEAR_STEPS as f64 * f.time_step();
        cache
            .surface_at(&scene, far, now, QueryFields::HEIGHT, &o)
            .unwrap();
        let exact = QueryOptions {
            time: TimeSampling::Exact,
            ..QueryOptions::default()
        };
        cache
            .surface_at(&scene, now, now, QueryFields::HEIGHT, &exact)
            .unwrap();
        assert!(cache.active_scenes().is_empty());
        // Within NEAR_STEPS of now (here NEAR_STEPS − 1 steps before it): active.
        let near = now - (NEAR_STEPS as f64 - 1.0) * f.time_step();
        cache
            .surface_at(&scene, near, now, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(cache.active_scenes(), vec![scene.uid]);
    }

    /// The frame-ahead step computes the frames the clock reaches in the next two grid steps,
    /// with the fields queries asked for, and nothing twice.
    #[test]
    fn compute_ahead_prepares_the_next_grid_frames() {
        let scene = builtin("storm");
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&scene);
        let now = f.grid_time(500) + 0.25 * f.time_step();
        cache
            .surface_at(&scene, now, now, QueryFields::ALL, &o)
            .unwrap();
        // Index 500 and 501 held; 502 and 503 are computed.
        assert_eq!(cache.compute_ahead(&scene, now, 1.0), 2);
        assert_eq!(cache.compute_ahead(&scene, now, 1.0), 0);
        let later = now + 2.0 * f.time_step();
        assert!(cache.has_frames(&scene, later, QueryFields::ALL, &o));
        // Running backwards, the frames before now.
        assert_eq!(cache.compute_ahead(&scene, now, -1.0), 2);
        // The clock moves on: near frames it left behind are dropped.
        let far_later = now + 40.0 * f.time_step();
        cache.compute_ahead(&scene, far_later, 1.0);
        assert!(!cache.has_frames(&scene, now, QueryFields::HEIGHT, &o));
        assert!(cache.near_len() <= 2 * NEAR_STEPS as usize + 1);
    }

    /// What the ahead loop asks on the reactor: whether a frame ahead is missing. Asking
    /// computes nothing, drops the near frames the clock has left behind and marks frames
    /// ahead that another scene of the same sea computed near for the asking scene, so they
    /// stay while its clock needs them.
    #[test]
    fn ahead_due_computes_nothing_and_keeps_the_near_frames_right() {
        let a = copy_of("storm", "storm-a", None);
        let b = copy_of("storm", "storm-b", None);
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&a);
        let dt = f.time_step();
        let now = f.grid_time(500) + 0.25 * dt;
        cache
            .surface_at(&a, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        let held = cache.transforms();
        assert!(cache.ahead_due(&a, now, 1.0), "502 and 503 are missing");
        assert_eq!(cache.transforms(), held, "asking computed a frame");
        assert_eq!(cache.compute_ahead(&a, now, 1.0), 2);
        assert!(!cache.ahead_due(&a, now, 1.0));
        assert!(
            !cache.ahead_due(&a, now, 0.0),
            "paused: only the frames at now"
        );
        // The copy finds a's frames: nothing due, and they become near for it.
        assert!(!cache.ahead_due(&b, now, 1.0));
        assert_eq!(cache.compute_ahead(&b, now, 1.0), 0);
        // a's clock jumps far ahead; asking drops what a left behind, not what b reads.
        let far = now + 40.0 * dt;
        let computed = cache.transforms();
        assert!(cache.ahead_due(&a, far, 1.0));
        assert_eq!(cache.transforms(), computed);
        assert!(cache.has_frames(&b, now + 2.0 * dt, QueryFields::HEIGHT, &o));
        // Then b's moves on too, and nobody is near those frames any more.
        assert!(cache.ahead_due(&b, far, 1.0));
        assert!(!cache.has_frames(&b, now, QueryFields::HEIGHT, &o));
        assert_eq!(cache.near_len(), 0);
    }

    /// `swell_fft_frames_total{by}`: who computed each frame. A query at now with nothing
    /// ahead computes its two frames itself (near); once the ahead loop has run, the next
    /// grid step's query computes none; a far-off time is the query's own; the body loop's
    /// reach counts as the body loop's.
    #[test]
    fn frames_are_counted_by_who_computed_them() {
        let scene = builtin("storm");
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&scene);
        let dt = f.time_step();
        let now = f.grid_time(500) + 0.25 * dt;
        let counts = || ComputedBy::ALL.map(|by| cache.computed(by));
        cache
            .surface_at(&scene, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(
            counts(),
            [0, 0, 2, 0],
            "[ahead, bodies, query_near, query_far]"
        );
        assert_eq!(cache.compute_ahead(&scene, now, 1.0), 2);
        let later = now + dt;
        cache
            .surface_at(&scene, later, later, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(counts(), [2, 0, 2, 0]);
        cache
            .surface_at(&scene, now + 60.0, later, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(counts(), [2, 0, 2, 2]);
        // Through later + 4Δ (index 505.25): 504 to 506 are new.
        assert_eq!(cache.compute_through(&scene, later, 1.0, 2.0 * dt), 3);
        assert_eq!(counts(), [2, 3, 2, 2]);
        let labels = ComputedBy::ALL.map(ComputedBy::label);
        assert_eq!(labels, ["ahead", "bodies", "query_near", "query_far"]);
    }

    /// The body loop's reach: the frames through one tick period past two grid steps, so the
    /// frame-ahead step at the next tick boundary finds nothing left to compute; a lead beyond
    /// the near frames stops at [`MAX_AHEAD_STEPS`], and a NaN lead counts as none.
    #[test]
    fn compute_through_reaches_the_next_tick() {
        let scene = builtin("storm");
        let cache = FrameCache::new(4);
        let f = fft(&scene);
        let dt = f.time_step();
        let now = f.grid_time(500) + 0.25 * dt;
        // Through now + 4Δ = index 504.25: 500 to 505.
        assert_eq!(cache.compute_through(&scene, now, 1.0, 2.0 * dt), 6);
        let next_boundary = f.grid_time(502) + 0.01 * dt;
        assert_eq!(cache.compute_ahead(&scene, next_boundary, 1.0), 0);
        // Capped at MAX_AHEAD_STEPS (5): index 505.25, so 506 is the one more.
        assert_eq!(cache.compute_through(&scene, now, 1.0, 1e9), 1);
        assert_eq!(cache.compute_through(&scene, now, 1.0, f64::INFINITY), 0);
        assert_eq!(cache.compute_through(&scene, now, 1.0, f64::NAN), 0);
        // Backwards, the same reach before now (index 496.25): 499 down to 496.
        assert_eq!(cache.compute_through(&scene, now, -1.0, 2.0 * dt), 4);
        assert!(cache.near_len() <= 2 * NEAR_STEPS as usize + 1);
    }

    /// A copy of built-in scene `id` under another id, its surface seed replaced by `seed` if
    /// given: another scene with (or without) an equal surface spec.
    fn copy_of(id: &str, copy: &str, seed: Option<u64>) -> Scene {
        let (_, mut spec) = crate::scene::builtin::specs()
            .into_iter()
            .find(|(i, _)| i == id)
            .unwrap();
        if let Some(seed) = seed {
            spec.surface.seed = seed;
        }
        Scene::build(copy, spec).unwrap()
    }

    /// The bits of a query at `t` answered from the cache, and the same query on the scene's
    /// own surface with no cache: they must be equal.
    fn cached_and_direct(
        cache: &FrameCache,
        scene: &Scene,
        t: f64,
        now: f64,
    ) -> (Vec<u64>, Vec<u64>) {
        let o = QueryOptions::default();
        let bits = |sea: &SurfaceAt<'_>| {
            let mut v = Vec::new();
            for (x, z) in [(0.0, 0.0), (12.5, -3.25), (-140.0, 77.7)] {
                let r = sea.query(glam::DVec2::new(x, z), QueryFields::ALL);
                v.extend(
                    [r.height, r.normal.x, r.normal.y, r.normal.z, r.jacobian].map(f64::to_bits),
                );
            }
            v
        };
        let cached = cache
            .surface_at(scene, t, now, QueryFields::ALL, &o)
            .unwrap();
        let direct = scene.surface.at(t, QueryFields::ALL, &o).unwrap();
        (bits(&cached), bits(&direct))
    }

    /// The saving of sharing: scenes built from equal surface specs (copies of one preset, clocks
    /// from the same epoch) read one set of frames, computed once, and answer with the bits of
    /// their own surface; a scene of another seed shares nothing; forgetting one copy keeps the
    /// frames the other reads.
    #[test]
    fn scenes_with_equal_surface_specs_compute_their_frames_once() {
        let a = copy_of("storm", "storm-a", None);
        let b = copy_of("storm", "storm-b", None);
        let other = copy_of("storm", "storm-c", Some(99));
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&a);
        let now = f.grid_time(700) + 0.5 * f.time_step();
        cache
            .surface_at(&a, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        // Two frames of height and displacement (Newton takes its Jacobian from the
        // displacement grids' interpolant): 3 grids.
        assert_eq!(cache.transforms(), 2 * 3);
        cache
            .surface_at(&b, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(
            cache.transforms(),
            2 * 3,
            "the copy computed its own frames"
        );
        assert_eq!(cache.compute_ahead(&a, now, 1.0), 2);
        assert_eq!(cache.compute_ahead(&b, now, 1.0), 0);
        assert_eq!(cache.transforms(), 4 * 3);
        cache
            .surface_at(&other, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(
            cache.transforms(),
            6 * 3,
            "another sea has frames of its own"
        );
        // A later normal query on the copy: exact bits (the frames widen on demand).
        let (cached, direct) = cached_and_direct(&cache, &b, now, now);
        assert_eq!(cached, direct);
        cache.forget_scene(a.uid);
        assert!(cache.has_frames(&b, now, QueryFields::ALL, &o));
        cache.forget_scene(b.uid);
        cache.forget_scene(other.uid);
        assert!(cache.is_empty(), "{} frames left", cache.len());
    }

    /// A copy whose clock reads another time shares no near frame with the first, and the
    /// first's clock moving on must not drop the frames the copy reads at its own now.
    #[test]
    fn a_shared_frame_stays_while_it_is_near_for_one_scene() {
        let a = copy_of("storm", "storm-a", None);
        let b = copy_of("storm", "storm-b", None);
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&a);
        let now = f.grid_time(700) + 0.5 * f.time_step();
        cache
            .surface_at(&a, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        cache
            .surface_at(&b, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        // a's clock jumps far ahead: b still reads frames 700 and 701.
        cache.compute_ahead(&a, now + 100.0, 1.0);
        assert!(cache.has_frames(&b, now, QueryFields::HEIGHT, &o));
        // Then b's moves on too: nobody is near them any more.
        cache.compute_ahead(&b, now + 100.0, 1.0);
        assert!(!cache.has_frames(&b, now, QueryFields::HEIGHT, &o));
        assert!(cache.near_len() <= 2 * NEAR_STEPS as usize + 1);
    }

    /// A height-only workload at now computes height and displacement (what Newton inversion
    /// reads): 3 of the 8 grids, never the slopes or Jacobian terms; a normal query asked later
    /// still gets the exact bits, and once nobody has asked for normals for 2·ACTIVE_FOR the
    /// frames ahead drop the slopes again.
    #[test]
    fn frames_ahead_carry_only_the_fields_asked_for_lately() {
        let scene = builtin("storm");
        let cache = FrameCache::new(4);
        let o = QueryOptions::default();
        let f = fft(&scene);
        let now = f.grid_time(900) + 0.5 * f.time_step();
        cache
            .surface_at(&scene, now, now, QueryFields::HEIGHT, &o)
            .unwrap();
        assert_eq!(cache.compute_ahead(&scene, now, 1.0), 2);
        assert_eq!(cache.transforms(), 4 * 3, "4 frames of 3 grids");
        // A normal query: its two frames widen to all 8 grids, with the exact bits.
        let (cached, direct) = cached_and_direct(&cache, &scene, now, now);
        assert_eq!(cached, direct);
        assert_eq!(cache.transforms(), 4 * 3 + 2 * 8);
        // The frames ahead now carry slopes too.
        let later = now + f.time_step();
        // 902 and 903 widen, 904 is new.
        assert_eq!(cache.compute_ahead(&scene, later, 1.0), 3);
        assert_eq!(cache.transforms(), 4 * 3 + 2 * 8 + 3 * 8);
        // Nobody has asked for normals for 2·ACTIVE_FOR: height queries alone again.
        {
            let mut g = cache.lock();
            let a = g.activity.get_mut(&scene.uid).unwrap();
            a.since = Instant::now().checked_sub(2 * ACTIVE_FOR).unwrap();
        }
        let t = later + f.time_step();
        cache
            .surface_at(&scene, t, t, QueryFields::HEIGHT, &o)
            .unwrap();
        let before = cache.transforms();
        let much_later = t + 3.0 * f.time_step();
        let computed = cache.compute_ahead(&scene, much_later, 1.0) as u64;
        assert!(computed > 0);
        assert_eq!(
            cache.transforms() - before,
            computed * 3,
            "slopes still computed ahead"
        );
        // And a normal query there is still exact.
        let (cached, direct) = cached_and_direct(&cache, &scene, much_later, much_later);
        assert_eq!(cached, direct);
    }
}
