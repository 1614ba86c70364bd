//! The shared FFT frame cache.
//!
//! An FFT frame (the grids of one FFT layer at one time) costs one inverse 2-D FFT per field and
//! is the same for every request that reads it, so it is computed once and shared. With the
//! model's default time sampling ([`TimeSampling::Grid`]) a query at any t reads the frames of
//! the one or two grid times around t, so every query between the same two grid times — in
//! particular every query at the scene's *now* — shares the same frames; entries are keyed by
//! grid index. Queries with `accuracy.time = "exact"` key their frame by the bits of t.
//!
//! Entries are keyed by `(scene, layer, grid index or t)`; each holds a `OnceLock`, so requests
//! that arrive together while a frame is being computed wait for that one computation instead of
//! repeating it. An entry holds the fields it was computed with; a request needing more replaces
//! it with a frame of the union.
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
    /// [`Scene::uid`]: one per built scene, so a replaced scene never reads the old frames.
    scene: u64,
    layer: usize,
    when: When,
}

impl Key {
    fn new(scene: &Scene, layer: usize, when: When) -> Key {
        Key {
            scene: scene.uid,
            layer,
            when,
        }
    }
}

type Slot = Arc<OnceLock<Arc<FftFrame>>>;

#[derive(Debug)]
struct Entry {
    slot: Slot,
    fields: FftFields,
    near: bool,
    used: u64,
    used_at: Instant,
}

/// What the cache knows of a scene's recent queries.
#[derive(Debug, Clone, Copy)]
struct Activity {
    last: Instant,
    /// Union of the FFT fields recent queries needed, per layer (computed ahead with these).
    wanted: [FftFields; swell_waves::surface::MAX_LAYERS],
}

#[derive(Debug, Default)]
struct Inner {
    entries: HashMap<Key, Entry>,
    activity: HashMap<u64, Activity>,
    clock: u64,
    far: usize,
    /// Scenes deleted or replaced ([`FrameCache::forget_scene`]), the newest
    /// [`RETIRED_KEPT`]: a query or the ahead loop that still holds such a scene computes its
    /// frame without caching it, so nothing re-fills the cache after the forget.
    retired: std::collections::HashSet<u64>,
    retired_order: std::collections::VecDeque<u64>,
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
        let mut far_dropped = 0;
        g.entries.retain(|k, e| {
            let keep = k.scene != uid;
            if !keep && !e.near {
                far_dropped += 1;
            }
            keep
        });
        g.far -= far_dropped;
        g.activity.remove(&uid);
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
        self.lock().entries.values().filter(|e| e.near).count()
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
        let a = g.activity.entry(scene.uid).or_insert(Activity {
            last: now,
            wanted: [FftFields::NONE; swell_waves::surface::MAX_LAYERS],
        });
        a.last = now;
        for (w, n) in a.wanted.iter_mut().zip(need) {
            *w = w.union(*n);
        }
    }

    /// The slot holding `key` with at least `need`, creating (or widening) it if absent, and
    /// evicting as the pools require.
    fn slot(&self, key: Key, need: FftFields, near: bool) -> (Slot, FftFields) {
        let mut guard = self.lock();
        let g = &mut *guard;
        if g.retired.contains(&key.scene) {
            // A scene deleted meanwhile: its frame is computed for this caller alone.
            return (Arc::new(OnceLock::new()), need);
        }
        g.clock += 1;
        let stamp = g.clock;
        let now = Instant::now();
        if let Some(e) = g.entries.get_mut(&key)
            && e.fields.contains(need)
        {
            e.used = stamp;
            e.used_at = now;
            if near && !e.near {
                // A far frame the clock has come close to joins the near pool.
                e.near = true;
                g.far -= 1;
            }
            return (e.slot.clone(), e.fields);
        }
        // Absent, or too few fields: a new slot with the union (waiters on an old slot still
        // get the frame they asked for).
        let fields = g.entries.get(&key).map_or(need, |e| e.fields.union(need));
        if let Some(old) = g.entries.remove(&key)
            && !old.near
        {
            g.far -= 1;
        }
        if near {
            // Near frames the clock has left behind or nobody reads go first.
            g.entries
                .retain(|_, e| !e.near || now.duration_since(e.used_at) < NEAR_IDLE);
        } else {
            while g.far >= self.capacity {
                let oldest = g
                    .entries
                    .iter()
                    .filter(|(_, e)| !e.near)
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
                near,
                used: stamp,
                used_at: now,
            },
        );
        (slot, fields)
    }

    /// Drops near frames of `scene` that are now more than [`NEAR_STEPS`] from the clock.
    fn prune_near(&self, scene: &Scene, now: f64) {
        self.lock().entries.retain(|k, e| {
            !e.near
                || k.scene != scene.uid
                || match scene.surface.layers().get(k.layer) {
                    Some(Layer::Fft(f)) => Self::is_near(f, k.when, now),
                    _ => false,
                }
        });
    }

    /// One frame of `layer` (index `i` of `scene`) at `when`, from the cache or computed now.
    fn frame(
        &self,
        scene: &Scene,
        i: usize,
        layer: &FftLayer,
        when: When,
        need: FftFields,
        now: f64,
    ) -> Arc<FftFrame> {
        let near = Self::is_near(layer, when, now);
        let key = Key::new(scene, i, when);
        let (slot, fields) = self.slot(key, need, near);
        slot.get_or_init(|| {
            let start = Instant::now();
            let frame = Arc::new(match when {
                When::Grid(n) => layer.grid_frame(n, fields),
                When::Exact(bits) => layer.frame(f64::from_bits(bits), fields),
            });
            metrics::counter!("swell_fft_frames_total").increment(1);
            metrics::histogram!("swell_fft_frame_seconds").record(start.elapsed().as_secs_f64());
            frame
        })
        .clone()
    }

    /// The FFT fields queries of `fields` with `options` need from every layer.
    fn needs(scene: &Scene, fields: QueryFields, options: &QueryOptions) -> Vec<FftFields> {
        scene
            .surface
            .layers()
            .iter()
            .map(|l| match l {
                Layer::Fft(f) => scene.surface.fft_fields_for(f, fields, options),
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
            .apply(self.frames_at(scene, t, now, fields, options))
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
        let surface = &scene.surface;
        if !surface.has_fft() || options.reference {
            return surface.at(t, fields, options);
        }
        // Check before computing anything: a bad t or option must not cost a frame.
        if !t.is_finite() {
            return surface.at_with_frames(t, Vec::new(), options);
        }
        options.validate()?;
        let needs = Self::needs(scene, fields, options);
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
                    let frame = self.frame(scene, i, f, a, needs[i], now);
                    let next = b.map(|b| self.frame(scene, i, f, b, needs[i], now));
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
        let needs = Self::needs(scene, fields, options);
        let g = self.lock();
        scene
            .surface
            .layers()
            .iter()
            .enumerate()
            .all(|(i, layer)| match layer {
                Layer::Fft(f) => {
                    let (a, b) = Self::whens(f, t, options.time);
                    [Some(a), b].into_iter().flatten().all(|when| {
                        let key = Key::new(scene, i, when);
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
        self.compute_through(scene, now, rate, 0.0)
    }

    /// [`FrameCache::compute_ahead`] reaching `lead` scene seconds further: every grid frame a
    /// read between `now` and `lead` + [`AHEAD_STEPS`] grid steps later in the clock's direction
    /// needs (at most [`MAX_AHEAD_STEPS`] grid steps in all). The body loop calls it right after
    /// its step with a tick period as `lead`, so the frames its next step and the ahead loop
    /// at the next tick boundary want are computed on the step's own thread after the states
    /// went out, not at that boundary beside the next step.
    pub fn compute_through(&self, scene: &Scene, now: f64, rate: f64, lead: f64) -> usize {
        let wanted = self.lock().activity.get(&scene.uid).map(|a| a.wanted);
        self.prune_near(scene, now);
        let mut computed = 0;
        for (i, layer) in scene.surface.layers().iter().enumerate() {
            let Layer::Fft(f) = layer else { continue };
            let need = wanted.map_or(FftFields::HEIGHT, |w| w[i].union(FftFields::HEIGHT));
            // f64::signum(0.0) is 1: a paused clock stays where it is.
            let direction = if rate > 0.0 {
                1.0
            } else if rate < 0.0 {
                -1.0
            } else {
                0.0
            };
            let step = f.time_step() * direction;
            // `max` drops a NaN lead; the layer's time step is positive (validated).
            let steps = (AHEAD_STEPS + lead.max(0.0) / f.time_step()).min(MAX_AHEAD_STEPS);
            let mut whens = Vec::with_capacity(steps as usize + 2);
            // Grid times up to `steps` (and the reach itself: it may fall between two).
            let reads = (0..=steps.ceil() as u32).map(|k| f64::from(k).min(steps));
            for k in reads {
                let (a, b) = Self::whens(f, now + step * k, TimeSampling::Grid);
                for w in [Some(a), b].into_iter().flatten() {
                    if !whens.contains(&w) {
                        whens.push(w);
                    }
                }
            }
            for when in whens {
                let key = Key::new(scene, i, when);
                let held = self
                    .lock()
                    .entries
                    .get(&key)
                    .is_some_and(|e| e.fields.contains(need));
                if !held {
                    self.frame(scene, i, f, when, need, now);
                    computed += 1;
                }
            }
        }
        computed
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
}
