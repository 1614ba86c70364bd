//! The shared FFT frame cache.
//!
//! An FFT frame (the grids of one FFT layer at one time) costs one inverse 2-D FFT per field and
//! is the same for every request at that time, so it is computed once and shared. Entries are
//! keyed by `(scene id, spec hash, layer, t bits, fields)`; each holds a `OnceLock`, so requests
//! that arrive together while the frame is being computed wait for that one computation instead
//! of repeating it. A request may use a cached frame holding more fields than it needs.
//!
//! The cache is bounded (least recently used entries go first). Computing happens in the caller's
//! thread, which must be a blocking one (`spawn_blocking`): `OnceLock::get_or_init` blocks the
//! waiters.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use swell_waves::fft::{FftFields, FftFrame};
use swell_waves::{Layer, QueryFields, QueryOptions, SpecError, SurfaceAt};

use crate::scene::Scene;

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct Key {
    scene: String,
    spec_hash: String,
    layer: usize,
    t_bits: u64,
    fields: [bool; 4],
}

fn field_bits(f: FftFields) -> [bool; 4] {
    [f.height, f.displacement, f.slopes, f.jacobian]
}

type Slot = Arc<OnceLock<Arc<FftFrame>>>;

#[derive(Debug, Default)]
struct Inner {
    entries: HashMap<Key, (Slot, u64)>,
    clock: u64,
}

/// A bounded cache of FFT frames shared by all requests.
#[derive(Debug)]
pub struct FrameCache {
    capacity: usize,
    inner: Mutex<Inner>,
}

impl FrameCache {
    /// A cache holding at most `capacity` frames (at least 1).
    pub fn new(capacity: usize) -> FrameCache {
        FrameCache {
            capacity: capacity.max(1),
            inner: Mutex::new(Inner::default()),
        }
    }

    /// Number of frames held (computed or being computed).
    pub fn len(&self) -> usize {
        self.lock().entries.len()
    }

    /// Whether the cache is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic while holding this lock cannot leave the map inconsistent (each operation is a
        // single insert/remove), so a poisoned lock is still usable.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The slot for a frame: an existing ready frame with at least `fields`, or the slot keyed
    /// by exactly `fields` (created if absent). Evicts the least recently used entry when full.
    fn slot(&self, scene: &Scene, layer: usize, t: f64, fields: FftFields) -> Slot {
        let mut g = self.lock();
        g.clock += 1;
        let stamp = g.clock;
        let key = Key {
            scene: scene.id.clone(),
            spec_hash: scene.spec_hash.clone(),
            layer,
            t_bits: t.to_bits(),
            fields: field_bits(fields),
        };
        if let Some((slot, used)) = g.entries.get_mut(&key) {
            *used = stamp;
            return slot.clone();
        }
        // A ready frame with more fields serves as well.
        let wider = g.entries.iter_mut().find(|(k, (slot, _))| {
            k.scene == key.scene
                && k.spec_hash == key.spec_hash
                && k.layer == layer
                && k.t_bits == key.t_bits
                && slot.get().is_some_and(|f| f.fields().contains(fields))
        });
        if let Some((_, (slot, used))) = wider {
            *used = stamp;
            return slot.clone();
        }
        while g.entries.len() >= self.capacity {
            let oldest = g
                .entries
                .iter()
                .min_by_key(|(_, (_, used))| *used)
                .map(|(k, _)| k.clone());
            match oldest {
                Some(k) => {
                    g.entries.remove(&k);
                }
                None => break,
            }
        }
        let slot: Slot = Arc::new(OnceLock::new());
        g.entries.insert(key, (slot.clone(), stamp));
        slot
    }

    /// The scene's surface at `t`, ready for queries of `fields` with `options`, with every FFT
    /// frame taken from (or computed into) the cache. Blocking: call from `spawn_blocking`.
    ///
    /// # Errors
    /// `t` not finite or invalid `options` (the model's error).
    pub fn surface_at<'s>(
        &self,
        scene: &'s Scene,
        t: f64,
        fields: QueryFields,
        options: &QueryOptions,
    ) -> Result<SurfaceAt<'s>, SpecError> {
        let surface = &scene.surface;
        if !surface.has_fft() {
            return surface.at(t, fields, options);
        }
        // Check before computing anything: a bad t or option must not cost a frame.
        if !t.is_finite() {
            return surface.at_with_frames(t, Vec::new(), options);
        }
        options.validate()?;
        let frames = surface
            .layers()
            .iter()
            .enumerate()
            .map(|(i, layer)| match layer {
                Layer::Fft(f) => {
                    let need = surface.fft_fields_for(f, fields, options);
                    let slot = self.slot(scene, i, t, need);
                    let frame = slot.get_or_init(|| {
                        let start = Instant::now();
                        let frame = Arc::new(f.frame(t, need));
                        let secs = start.elapsed().as_secs_f64();
                        metrics::counter!("swell_fft_frames_total").increment(1);
                        metrics::histogram!("swell_fft_frame_seconds").record(secs);
                        frame
                    });
                    Some(frame.clone())
                }
                _ => None,
            })
            .collect();
        surface.at_with_frames(t, frames, options)
    }
}
