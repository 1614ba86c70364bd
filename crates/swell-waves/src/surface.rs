//! A [`Surface`] is the sum of the layers a scene declares; a [`SurfaceAt`] is that surface frozen
//! at one time, ready to answer point queries.
//!
//! Only what a scene declares is built (a surface without an FFT layer holds no FFT state), and a
//! [`SurfaceAt`] computes only the FFT fields its queries need.

use std::sync::{Arc, OnceLock};

use glam::{DVec2, DVec3, Vec3};

use crate::error::{SpecError, finite, in_range, positive};
use crate::fft::{FftFields, FftFrame, FftLayer, FftReads, FftSample, FftSpec, lerp_samples};
use crate::gerstner::{GerstnerLayer, GerstnerLayerSpec, fold_number};
use crate::math::splitmix64;
use crate::particles::{Impacts, ParticleField, ParticleLayer, ParticleLayerSpec};
use crate::query::{Precision, QueryFields, QueryOptions, TimeSampling};
use crate::sine::{SineLayer, SineLayerSpec};
use crate::spectrum::Dispersion;
use crate::wave::{Lanes, LanesF32, SurfaceSample, Wave, WaveSoA};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Smallest gravity a surface may declare, m/s²: far below any body a game puts water on
/// (the Moon is 1.62); a subnormal gravity once pushed the spectra's quadrature to ~1e-320 rad/m.
pub const MIN_GRAVITY: f64 = 0.01;
/// Largest gravity a surface may declare, m/s² (Jupiter is 24.8).
pub const MAX_GRAVITY: f64 = 1000.0;

/// Most layers a surface may declare.
pub const MAX_LAYERS: usize = 16;

/// The wave part of a scene spec: which layers, the seed, gravity and depth.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SurfaceSpec {
    /// Master seed; each layer's seed is `splitmix64(seed ^ splitmix64(index))` unless the layer
    /// gives its own. Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub seed: u64,
    /// Gravity g, m/s², in [[`MIN_GRAVITY`], [`MAX_GRAVITY`]]. Default 9.81.
    #[cfg_attr(feature = "serde", serde(default = "default_gravity"))]
    pub gravity: f64,
    /// Water depth h, m; absent means deep water.
    #[cfg_attr(feature = "serde", serde(default))]
    pub depth: Option<f64>,
    /// The layers, summed in order (1..=16).
    pub layers: Vec<LayerSpec>,
}

#[cfg(feature = "serde")]
fn default_gravity() -> f64 {
    crate::spectrum::STANDARD_GRAVITY
}

/// One layer of a surface spec, tagged by `kind` on the wire.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(tag = "kind", rename_all = "snake_case"))]
pub enum LayerSpec {
    /// Compound sine.
    Sine(SineLayerSpec),
    /// Gerstner waves, explicit and generated.
    Gerstner(GerstnerLayerSpec),
    /// Tessendorf FFT ocean.
    Fft(FftSpec),
    /// Wave particles: ambient particles and impact ripples.
    Particles(ParticleLayerSpec),
}

impl LayerSpec {
    /// The layer kind as written on the wire: `sine`, `gerstner`, `fft` or `particles`.
    pub fn kind(&self) -> &'static str {
        match self {
            LayerSpec::Sine(_) => "sine",
            LayerSpec::Gerstner(_) => "gerstner",
            LayerSpec::Fft(_) => "fft",
            LayerSpec::Particles(_) => "particles",
        }
    }
}

/// A built layer.
#[derive(Debug)]
pub enum Layer {
    /// Compound sine.
    Sine(SineLayer),
    /// Gerstner.
    Gerstner(GerstnerLayer),
    /// FFT ocean (boxed: it holds the spectrum and transform plans).
    Fft(Box<FftLayer>),
    /// Wave particles (boxed: it holds the ambient particle arrays).
    Particles(Box<ParticleLayer>),
}

impl Layer {
    /// The analytic waves of a sine or Gerstner layer; empty for FFT and particle layers.
    pub fn waves(&self) -> &[Wave] {
        match self {
            Layer::Sine(l) => l.waves(),
            Layer::Gerstner(l) => l.waves(),
            Layer::Fft(_) | Layer::Particles(_) => &[],
        }
    }
}

/// A validated, built surface: immutable, `Send + Sync`, shareable across threads.
#[derive(Debug)]
pub struct Surface {
    layers: Vec<Layer>,
    /// The analytic layers' waves as arrays for the block kernels (`None` for FFT layers).
    soa: Vec<Option<WaveSoA>>,
    dispersion: Dispersion,
    fold: f64,
    horizontal: bool,
}

/// The seed of layer `index` under the surface seed: `splitmix64(seed ^ splitmix64(index))`.
pub fn layer_seed(seed: u64, index: usize) -> u64 {
    splitmix64(seed ^ splitmix64(index as u64))
}

impl Surface {
    /// Validates and builds every layer.
    ///
    /// # Errors
    /// No layers or more than [`MAX_LAYERS`]; bad gravity or depth; any layer error (its field
    /// path starts with `layers[i]`); a total Gerstner fold number ≥ 1 across layers (field
    /// `layers`).
    pub fn new(spec: &SurfaceSpec) -> Result<Surface, SpecError> {
        in_range("gravity", spec.gravity, MIN_GRAVITY, MAX_GRAVITY)?;
        if let Some(h) = spec.depth {
            positive("depth", h)?;
        }
        let dispersion = Dispersion::new(spec.gravity, spec.depth)?;
        if spec.layers.is_empty() || spec.layers.len() > MAX_LAYERS {
            return Err(SpecError::BadLength {
                field: "layers".into(),
                len: spec.layers.len(),
                allowed: format!("1..={MAX_LAYERS}"),
            });
        }
        let mut layers = Vec::with_capacity(spec.layers.len());
        for (i, l) in spec.layers.iter().enumerate() {
            let field = format!("layers[{i}]");
            let seed = layer_seed(spec.seed, i);
            layers.push(match l {
                LayerSpec::Sine(s) => Layer::Sine(SineLayer::new(s, &dispersion, &field)?),
                LayerSpec::Gerstner(g) => Layer::Gerstner(GerstnerLayer::new(
                    g,
                    g.seed.unwrap_or(seed),
                    &dispersion,
                    &field,
                )?),
                LayerSpec::Fft(f) => Layer::Fft(Box::new(FftLayer::new(
                    f,
                    f.seed.unwrap_or(seed),
                    dispersion,
                    &field,
                )?)),
                LayerSpec::Particles(p) => Layer::Particles(Box::new(ParticleLayer::new(
                    p,
                    p.seed.unwrap_or(seed),
                    dispersion,
                    &field,
                )?)),
            });
        }
        let gerstner: Vec<Wave> = layers
            .iter()
            .filter(|l| matches!(l, Layer::Gerstner(_)))
            .flat_map(|l| l.waves().iter().copied())
            .collect();
        let fold = fold_number(&gerstner);
        if fold >= 1.0 {
            return Err(SpecError::Folding {
                field: "layers".into(),
                fold,
            });
        }
        let horizontal = layers.iter().any(|l| match l {
            Layer::Sine(_) | Layer::Particles(_) => false,
            Layer::Gerstner(g) => g.waves().iter().any(|w| w.steepness > 0.0),
            Layer::Fft(f) => f.choppiness() > 0.0,
        });
        let soa = layers
            .iter()
            .map(|l| match l {
                Layer::Sine(_) | Layer::Gerstner(_) => Some(WaveSoA::new(l.waves())),
                Layer::Fft(_) | Layer::Particles(_) => None,
            })
            .collect();
        Ok(Surface {
            layers,
            soa,
            dispersion,
            fold,
            horizontal,
        })
    }

    /// The built layers, in spec order.
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// The dispersion relation (gravity and depth).
    pub fn dispersion(&self) -> Dispersion {
        self.dispersion
    }

    /// Total Gerstner fold number `Σ Q·k·A` across all Gerstner layers (< 1).
    pub fn fold_number(&self) -> f64 {
        self.fold
    }

    /// Whether any layer moves the surface horizontally (then heights need inversion).
    pub fn has_horizontal_motion(&self) -> bool {
        self.horizontal
    }

    /// Whether any layer is an FFT ocean.
    pub fn has_fft(&self) -> bool {
        self.layers.iter().any(|l| matches!(l, Layer::Fft(_)))
    }

    /// Whether any layer is a particle layer.
    pub fn has_particles(&self) -> bool {
        self.layers.iter().any(|l| matches!(l, Layer::Particles(_)))
    }

    /// The first particle layer, the one impacts ripple on ([`SurfaceAt::with_impacts`]).
    pub fn impact_layer(&self) -> Option<&ParticleLayer> {
        self.layers.iter().find_map(|l| match l {
            Layer::Particles(p) => Some(&**p),
            _ => None,
        })
    }

    /// The FFT fields that queries for `fields` need from layer `layer`: height always;
    /// horizontal displacement when the layer is choppy (to invert, by either method: Newton
    /// reads no Jacobian grid); the Jacobian terms for normals and Jacobians of a choppy layer;
    /// slopes for normals.
    pub fn fft_fields_for(&self, layer: &FftLayer, fields: QueryFields) -> FftFields {
        let choppy = layer.choppiness() > 0.0;
        let mut f = FftFields::HEIGHT;
        if choppy {
            // Newton's steps take their Jacobian from the displacement grids' interpolant
            // (`FftFrame::newton_jacobian`): the Jacobian grids are for the fields that report it.
            f = f.union(FftFields::DISPLACEMENT);
            if fields.normal || fields.jacobian {
                f = f.union(FftFields::JACOBIAN);
            }
        }
        if fields.normal {
            f = f.union(FftFields::SLOPES);
        }
        f
    }

    /// Computes the FFT frame of layer `layer` at time `t` with `fields`; `None` if that layer is
    /// not an FFT layer. Callers that share frames between requests (a server cache) use this
    /// with [`Surface::at_with_frames`].
    pub fn fft_frame(&self, layer: usize, t: f64, fields: FftFields) -> Option<FftFrame> {
        match self.layers.get(layer)? {
            Layer::Fft(f) => Some(f.frame(t, fields)),
            _ => None,
        }
    }

    /// The surface at time `t` (s), ready for queries of `fields`: computes the FFT frames
    /// those queries need (with [`TimeSampling::Grid`], the one or two grid frames around `t`;
    /// with [`TimeSampling::Exact`], the frame at `t`).
    ///
    /// # Errors
    /// `t` not finite, or invalid `options`.
    pub fn at(
        &self,
        t: f64,
        fields: QueryFields,
        options: &QueryOptions,
    ) -> Result<SurfaceAt<'_>, SpecError> {
        self.at_via(t, fields, options, |_, f, t, need| {
            Arc::new(f.frame(t, need))
        })
    }

    /// [`Surface::at`] with the FFT frames from `memo` when it has them (same bits: a frame is a
    /// function of its layer, time and fields), and computed and kept there otherwise. For
    /// callers that step bodies without a server's cache: a tick reads its grid frames several
    /// times (substeps, velocity grids) and the next tick reads most of them again.
    ///
    /// # Errors
    /// `t` not finite, or invalid `options`.
    pub fn at_memo(
        &self,
        t: f64,
        fields: QueryFields,
        options: &QueryOptions,
        memo: &FrameMemo,
    ) -> Result<SurfaceAt<'_>, SpecError> {
        self.at_via(t, fields, options, |i, f, t, need| {
            memo.frame(i, f, t, need)
        })
    }

    /// [`Surface::at`] with `frame(layer index, layer, time, fields)` computing each FFT frame.
    fn at_via(
        &self,
        t: f64,
        fields: QueryFields,
        options: &QueryOptions,
        mut compute: impl FnMut(usize, &FftLayer, f64, FftFields) -> Arc<FftFrame>,
    ) -> Result<SurfaceAt<'_>, SpecError> {
        finite("t", t)?;
        options.validate()?;
        let frames = if options.reference {
            vec![None; self.layers.len()]
        } else {
            self.layers
                .iter()
                .enumerate()
                .map(|(i, l)| match l {
                    Layer::Fft(f) => {
                        let need = self.fft_fields_for(f, fields);
                        let mut frame = |t| compute(i, f, t, need);
                        Some(match options.time {
                            TimeSampling::Exact => LayerFrames::exact(frame(t)),
                            TimeSampling::Grid => {
                                let p = f.grid_position(t);
                                LayerFrames {
                                    frame: frame(f.grid_time(p.index)),
                                    next: (p.weight > 0.0).then(|| frame(f.grid_time(p.next))),
                                }
                            }
                        })
                    }
                    _ => None,
                })
                .collect()
        };
        self.at_with_frames(t, frames, options)
    }

    /// The surface at time `t` with FFT frames supplied by the caller (a cache shared between
    /// requests): one entry per layer, `Some` for each FFT layer, with at least the fields the
    /// queries need ([`Surface::fft_fields_for`]) and computed at the times `options.time` reads:
    /// with [`TimeSampling::Grid`], `frame` at [`FftLayer::grid_time`] of the
    /// [`FftLayer::grid_position`]'s `index` and `next` at its `next` (`None` when the weight is
    /// 0); with [`TimeSampling::Exact`], `frame` at `t` and no `next`. The frames' times are
    /// checked, so a snapshot can never mix times: the interpolation weight is computed here,
    /// from `t`.
    ///
    /// # Errors
    /// `t` not finite, invalid `options`, or a frame missing, extra or at the wrong time
    /// ([`SpecError::Inconsistent`], field `frames`).
    pub fn at_with_frames(
        &self,
        t: f64,
        frames: Vec<Option<LayerFrames>>,
        options: &QueryOptions,
    ) -> Result<SurfaceAt<'_>, SpecError> {
        finite("t", t)?;
        options.validate()?;
        let inconsistent = |reason: &str| SpecError::Inconsistent {
            field: "frames".into(),
            reason: reason.into(),
        };
        let mut held = Vec::with_capacity(self.layers.len());
        if options.reference {
            held.resize(self.layers.len(), None);
        } else {
            if frames.len() != self.layers.len() {
                return Err(inconsistent("one entry is needed per layer"));
            }
            for (layer, given) in self.layers.iter().zip(frames) {
                held.push(match (layer, given) {
                    (Layer::Fft(f), Some(given)) => {
                        Some(Held::new(f, t, given, options.time).ok_or_else(|| {
                            inconsistent(
                                "an FFT layer's frames are not at the times this query reads",
                            )
                        })?)
                    }
                    (Layer::Fft(_), None) => {
                        return Err(inconsistent("an FFT layer has no frame"));
                    }
                    (_, Some(_)) => {
                        return Err(inconsistent("a layer that is not FFT was given a frame"));
                    }
                    (_, None) => None,
                });
            }
        }
        // Particle layers at t, without impacts ([`SurfaceAt::with_impacts`] adds them). Cheap:
        // their grids are built on the first query. Empty when there is no particle layer.
        let particles = if self.has_particles() {
            self.layers
                .iter()
                .map(|l| match l {
                    Layer::Particles(p) => p.field(t, None).map(|f| Some(Arc::new(f))),
                    _ => Ok(None),
                })
                .collect::<Result<Vec<_>, _>>()?
        } else {
            Vec::new()
        };
        Ok(SurfaceAt {
            surface: self,
            t,
            frames: held,
            options: *options,
            velocities: Vec::new(),
            offsets: OnceLock::new(),
            particles,
        })
    }

    /// Every analytic layer's f32 phase offsets at `t` (one small reduction per wave).
    fn phase_offsets(&self, t: f64) -> Vec<Vec<f64>> {
        self.soa
            .iter()
            .map(|soa| soa.as_ref().map_or_else(Vec::new, |s| s.phase_offsets(t)))
            .collect()
    }
}

/// The frames one FFT layer is read from at a snapshot's time, as a caller supplies them to
/// [`Surface::at_with_frames`]: the frame at the grid time at or before t (or at t itself), and
/// the frame at the next grid time when t lies strictly between two.
#[derive(Debug, Clone)]
pub struct LayerFrames {
    /// The frame at [`FftLayer::grid_time`] of the grid position's `index` (or at t, exact).
    pub frame: Arc<FftFrame>,
    /// The frame at the grid position's `next` time, when its weight is above 0.
    pub next: Option<Arc<FftFrame>>,
}

impl LayerFrames {
    /// One frame computed at exactly the query time.
    pub fn exact(frame: Arc<FftFrame>) -> LayerFrames {
        LayerFrames { frame, next: None }
    }
}

/// The last few FFT frames [`Surface::at_memo`] computed, keyed by layer, time and fields: at
/// most [`FrameMemo::CAPACITY`], the oldest dropped first. Safe to share between threads.
#[derive(Debug, Default)]
pub struct FrameMemo {
    frames: std::sync::Mutex<Vec<MemoEntry>>,
}

/// One frame of a [`FrameMemo`]: layer index, time bits, fields, the frame.
type MemoEntry = (usize, u64, FftFields, Arc<FftFrame>);

impl FrameMemo {
    /// Most frames kept: a body tick on one FFT layer reads grid frames n − 1, n and n + 1 (and
    /// n + 2 with substeps between grid times), and the next tick reads all but the oldest.
    pub const CAPACITY: usize = 6;

    /// An empty memo.
    pub fn new() -> FrameMemo {
        FrameMemo::default()
    }

    /// Number of frames kept.
    pub fn len(&self) -> usize {
        self.frames.lock().map_or(0, |g| g.len())
    }

    /// Whether no frame is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Layer `index`'s frame at `t` with at least `need`, from the memo or computed (outside
    /// the lock) and kept. A poisoned lock only means nothing is kept.
    fn frame(&self, index: usize, layer: &FftLayer, t: f64, need: FftFields) -> Arc<FftFrame> {
        let found = self.frames.lock().ok().and_then(|g| {
            g.iter()
                .find(|(i, at, has, _)| {
                    *i == index && *at == t.to_bits() && has.union(need) == *has
                })
                .map(|(.., f)| Arc::clone(f))
        });
        if let Some(f) = found {
            return f;
        }
        let f = Arc::new(layer.frame(t, need));
        if let Ok(mut g) = self.frames.lock() {
            if g.len() >= Self::CAPACITY {
                g.remove(0);
            }
            g.push((index, t.to_bits(), need, Arc::clone(&f)));
        }
        f
    }
}

/// A layer's frames in a snapshot, with the weight of `next` (checked against the time).
#[derive(Debug, Clone)]
pub(crate) struct Held {
    frame: Arc<FftFrame>,
    next: Option<(Arc<FftFrame>, f64)>,
}

impl Held {
    /// `given` checked against what `time` reads at `t`; `None` if a frame is at another time.
    fn new(layer: &FftLayer, t: f64, given: LayerFrames, time: TimeSampling) -> Option<Held> {
        let same = |frame: &FftFrame, at: f64| frame.t().to_bits() == at.to_bits();
        match time {
            TimeSampling::Exact => (same(&given.frame, t) && given.next.is_none()).then(|| Held {
                frame: given.frame,
                next: None,
            }),
            TimeSampling::Grid => {
                let p = layer.grid_position(t);
                if !same(&given.frame, layer.grid_time(p.index)) {
                    return None;
                }
                let next = match given.next {
                    _ if p.weight == 0.0 => None,
                    Some(b) if same(&b, layer.grid_time(p.next)) => Some((b, p.weight)),
                    _ => return None,
                };
                Some(Held {
                    frame: given.frame,
                    next,
                })
            }
        }
    }

    /// The layer at `p0`: the frame's sample, or `a + (b − a)·w` between the two frames.
    #[inline(always)]
    fn sample(&self, p0: DVec2, filter: crate::fft::SampleFilter, reads: FftReads) -> FftSample {
        let a = self.frame.sample_some(p0, filter, reads);
        match &self.next {
            None => a,
            Some((b, w)) => lerp_samples(&a, &b.sample_some(p0, filter, reads), *w),
        }
    }

    fn transforms(&self) -> usize {
        self.frame.transforms() + self.next.as_ref().map_or(0, |(b, _)| b.transforms())
    }
}

/// One point of [`SurfaceAt::displacement_normal_f32`], in single precision.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfacePointF32 {
    /// `(Dx, y, Dz)` of the undisplaced point, m.
    pub displacement: Vec3,
    /// Unit normal of the displaced surface there (y up).
    pub normal: Vec3,
}

/// A surface frozen at time `t`: cheap to query from many threads at once.
#[derive(Debug, Clone)]
pub struct SurfaceAt<'s> {
    pub(crate) surface: &'s Surface,
    pub(crate) t: f64,
    /// Per layer, the FFT frames it is read from (`None` for analytic layers and in reference
    /// mode).
    pub(crate) frames: Vec<Option<Held>>,
    pub(crate) options: QueryOptions,
    /// Orbital velocity grids per layer (`Some` for FFT layers once computed; empty until
    /// [`SurfaceAt::with_velocity`] or [`SurfaceAt::with_velocity_frames`]).
    pub(crate) velocities: Vec<Option<Arc<crate::fft::FftVelocityFrame>>>,
    /// Per analytic layer, the f32 fast path's phase offsets at `t` (turns, see
    /// [`WaveSoA::phase_offsets`]); empty for FFT layers. Computed on the first f32 evaluation
    /// ([`SurfaceAt::lanes_f32`]), so f64 snapshots never pay for them; the values depend only
    /// on the surface and `t`, so when they are computed changes no bit.
    pub(crate) offsets: OnceLock<Vec<Vec<f64>>>,
    /// Per layer, the particle layer at `t` (`Some` for particle layers); empty when the
    /// surface has none.
    pub(crate) particles: Vec<Option<Arc<ParticleField>>>,
}

impl SurfaceAt<'_> {
    /// The time, s.
    pub fn t(&self) -> f64 {
        self.t
    }

    /// The one frame layer `layer` is read from, when it reads exactly one (a grid time, or an
    /// exact frame); `None` for other layers, between grid times and in reference mode.
    pub(crate) fn single_frame(&self, layer: usize) -> Option<&Arc<FftFrame>> {
        match self.frames.get(layer)? {
            Some(Held { frame, next: None }) => Some(frame),
            _ => None,
        }
    }

    /// The surface.
    pub fn surface(&self) -> &Surface {
        self.surface
    }

    /// The query options in force.
    pub fn options(&self) -> &QueryOptions {
        &self.options
    }

    /// This snapshot with the ripples of `impacts` on the surface's first particle layer
    /// ([`Surface::impact_layer`]): the rings alive at `t` are listed now, their grid is built
    /// on the first query. On a surface without a particle layer the impacts change nothing.
    ///
    /// # Errors
    /// More than [`crate::particles::ripple::MAX_LIVE_RINGS`] rings alive at t (field
    /// `impacts`).
    pub fn with_impacts(mut self, impacts: &Impacts) -> Result<Self, SpecError> {
        let surface = self.surface;
        let first = surface
            .layers
            .iter()
            .enumerate()
            .find_map(|(i, l)| match l {
                Layer::Particles(p) => Some((i, p)),
                _ => None,
            });
        if let Some((i, p)) = first {
            self.particles[i] = Some(Arc::new(p.field(self.t, Some(impacts))?));
        }
        Ok(self)
    }

    /// The particle layer `i` of this snapshot at its time, if layer `i` is a particle layer.
    pub fn particle_field(&self, i: usize) -> Option<&ParticleField> {
        self.particles.get(i).and_then(|f| f.as_deref())
    }

    /// Adds particle layer `i`'s height and slopes at `p` to lane `l` (`y` and its
    /// derivatives only: particles move the surface vertically).
    #[inline]
    fn add_particles<const B: usize>(
        &self,
        i: usize,
        layer: &ParticleLayer,
        points: &[DVec2; B],
        derivatives: bool,
        out: &mut Lanes<B>,
    ) {
        if let Some(field) = self.particle_field(i) {
            for (l, &p) in points.iter().enumerate() {
                let (h, g) = field.sample(layer, p, 0.0);
                out.disp[1][l] += h;
                if derivatives {
                    out.d_dx[1][l] += g.x;
                    out.d_dz[1][l] += g.y;
                }
            }
        }
    }

    /// Total inverse FFTs run to build this snapshot's frames.
    pub fn transforms(&self) -> usize {
        self.frames.iter().flatten().map(Held::transforms).sum()
    }

    /// Sum of every layer's displacement `(Dx, y, Dz)` at the undisplaced point `p0`, and its
    /// derivatives if `derivatives` (otherwise those are zero).
    ///
    /// This is [`SurfaceAt::sample_lanes`] with a block of one point: the single and batch
    /// paths run the same code, so they agree to the bit.
    pub fn sample(&self, p0: DVec2, derivatives: bool) -> SurfaceSample {
        self.sample_lanes(&[p0], derivatives).get(0)
    }

    /// One FFT layer at `p0`: from its frame(s) with the snapshot's filter, or by direct
    /// summation at t when the snapshot is a reference one (or has no frame for the layer).
    #[inline(always)]
    pub(crate) fn fft_sample(
        &self,
        layer: &FftLayer,
        frames: &Option<Held>,
        p0: DVec2,
        reads: FftReads,
    ) -> FftSample {
        match frames {
            Some(held) if !self.options.reference => held.sample(p0, self.options.filter, reads),
            _ => layer.sample_reference(p0, self.t),
        }
    }

    /// [`SurfaceAt::sample`] for a block of `B` points at once (the analytic layers go through
    /// the vectorised [`WaveSoA`] kernel). Lane `l` is bit-identical to `sample(points[l])`.
    #[inline(always)]
    pub fn sample_lanes<const B: usize>(&self, points: &[DVec2; B], derivatives: bool) -> Lanes<B> {
        if self.options.precision == Precision::F32 {
            return self.lanes_f32(points, derivatives).widen();
        }
        self.sample_lanes_f64::<B, false>(
            points,
            FftReads::every(derivatives),
            &[true; B],
            &mut [[0.0; B]; 3],
            true,
        )
    }

    /// The f64 body of [`SurfaceAt::sample_lanes`] (whatever the snapshot's precision); with
    /// `V`, the analytic layers' particle velocities go into `velocity` from the same `sin_cos`
    /// ([`WaveSoA::accumulate_lanes_with_velocity`]), unfiltered, in layer order. Other layers add
    /// no velocity here: the caller adds theirs at the point it keeps
    /// ([`SurfaceAt::water_lanes`]). FFT layers are read only for the lanes `wanted` marks (a
    /// frame read is scalar, one lane at a time); the others' FFT terms are left out, so only
    /// wanted lanes carry the full sample. Without `particles`, particle layers are left out
    /// too: they move the surface vertically only, so an inversion round, which reads the
    /// horizontal displacement and its slopes, does not need them.
    #[inline(always)]
    pub(crate) fn sample_lanes_f64<const B: usize, const V: bool>(
        &self,
        points: &[DVec2; B],
        reads: FftReads,
        wanted: &[bool; B],
        velocity: &mut [[f64; B]; 3],
        particles: bool,
    ) -> Lanes<B> {
        let derivatives = reads != FftReads::Displacement;
        let x: [f64; B] = std::array::from_fn(|l| points[l].x);
        let z: [f64; B] = std::array::from_fn(|l| points[l].y);
        let mut out = Lanes::<B>::default();
        for (i, ((layer, frame), soa)) in self
            .surface
            .layers
            .iter()
            .zip(&self.frames)
            .zip(&self.surface.soa)
            .enumerate()
        {
            match (layer, soa) {
                (Layer::Fft(f), _) => {
                    for (l, &p0) in points.iter().enumerate() {
                        if !wanted[l] {
                            continue;
                        }
                        add_fft(
                            &mut out,
                            l,
                            &self.fft_sample(f, frame, p0, reads),
                            derivatives,
                        );
                    }
                }
                (Layer::Particles(p), _) => {
                    if particles {
                        self.add_particles(i, p, points, derivatives, &mut out);
                    }
                }
                (_, Some(soa)) if V => soa.accumulate_lanes_with_velocity(
                    &x,
                    &z,
                    self.t,
                    derivatives,
                    &mut out,
                    velocity,
                ),
                (_, Some(soa)) => soa.accumulate_lanes(&x, &z, self.t, derivatives, &mut out),
                (_, None) => {}
            }
        }
        out
    }

    /// The single-precision fast path for a block of `B` points (whatever the snapshot's
    /// [`Precision`]): analytic layers through [`WaveSoA::accumulate_lanes_f32`], FFT layers read
    /// from their frames in f64 and added to the f32 sums, layers in order. Lane `l` depends
    /// only on `points[l]`.
    #[inline(always)]
    pub fn lanes_f32<const B: usize>(&self, points: &[DVec2; B], derivatives: bool) -> LanesF32<B> {
        self.lanes_f32_with(points, FftReads::every(derivatives), true)
    }

    /// [`SurfaceAt::lanes_f32`] reading FFT layers' grids as `reads` says (derivatives unless
    /// `Displacement`), leaving particle layers out unless `particles` (see
    /// [`SurfaceAt::sample_lanes_f64`]).
    #[inline(always)]
    pub(crate) fn lanes_f32_with<const B: usize>(
        &self,
        points: &[DVec2; B],
        reads: FftReads,
        particles: bool,
    ) -> LanesF32<B> {
        let derivatives = reads != FftReads::Displacement;
        let x: [f64; B] = std::array::from_fn(|l| points[l].x);
        let z: [f64; B] = std::array::from_fn(|l| points[l].y);
        let mut out = LanesF32::<B>::default();
        let offsets = self
            .offsets
            .get_or_init(|| self.surface.phase_offsets(self.t));
        for (i, (((layer, frame), soa), offsets)) in self
            .surface
            .layers
            .iter()
            .zip(&self.frames)
            .zip(&self.surface.soa)
            .zip(offsets)
            .enumerate()
        {
            match (layer, soa) {
                (Layer::Fft(f), _) => {
                    for (l, &p0) in points.iter().enumerate() {
                        let mut one = Lanes::<1>::default();
                        add_fft(
                            &mut one,
                            0,
                            &self.fft_sample(f, frame, p0, reads),
                            derivatives,
                        );
                        out.add(l, &one.get(0));
                    }
                }
                (Layer::Particles(_), _) if !particles => {}
                (Layer::Particles(p), _) => {
                    // Summed in f64 like an FFT layer's grid read, then joins the f32 sums.
                    for (l, &p0) in points.iter().enumerate() {
                        let mut one = Lanes::<1>::default();
                        self.add_particles(i, p, &[p0], derivatives, &mut one);
                        out.add(l, &one.get(0));
                    }
                }
                (_, Some(soa)) => soa.accumulate_lanes_f32(&x, &z, offsets, derivatives, &mut out),
                (_, None) => {}
            }
        }
        out
    }

    /// [`SurfaceAt::sample`] for every point of `points` into `out` (same length), in blocks
    /// of [`crate::wave::BLOCK`]: bit-identical to calling `sample` point by point.
    ///
    /// # Panics
    /// If `out.len() != points.len()`.
    pub fn sample_batch(&self, points: &[DVec2], derivatives: bool, out: &mut [SurfaceSample]) {
        self.sample_batch_as(points, derivatives, out, self.options.precision);
    }

    /// Single-precision variant of [`SurfaceAt::sample_batch`] — an approximation knob, not the
    /// default: analytic layers use [`WaveSoA::accumulate_lanes_f32`] (phases formed and reduced
    /// in f64, then f32 sin/cos, products and sums); FFT layers are read from their f64 frames
    /// as usual. Deterministic, but not bit-identical to the f64 path (see `docs/accuracy.md` for
    /// its error).
    ///
    /// # Panics
    /// If `out.len() != points.len()`.
    pub fn sample_batch_f32(&self, points: &[DVec2], derivatives: bool, out: &mut [SurfaceSample]) {
        self.sample_batch_as(points, derivatives, out, Precision::F32);
    }

    /// The batch loop behind [`SurfaceAt::sample_batch`] and [`SurfaceAt::sample_batch_f32`].
    fn sample_batch_as(
        &self,
        points: &[DVec2],
        derivatives: bool,
        out: &mut [SurfaceSample],
        precision: Precision,
    ) {
        assert_eq!(points.len(), out.len(), "one output per point");
        for_blocks(
            points,
            out,
            #[inline(always)]
            |block, dst| {
                let lanes = match precision {
                    Precision::F32 => self.lanes_f32(block, derivatives).widen(),
                    Precision::F64 => self.sample_lanes(block, derivatives),
                };
                for (l, o) in dst.iter_mut().enumerate() {
                    *o = lanes.get(l);
                }
            },
        );
    }

    /// The fast path for rendering and physics probes: displacement `(Dx, y, Dz)` and unit
    /// normal of every point of `points` (undisplaced points, as in [`SurfaceAt::sample`]), in
    /// single precision ([`Precision::F32`]: f64 phase reduction, f32 sin/cos and sums; the
    /// normal from [`LanesF32::normals`]). Deterministic and independent of the batch: point `i`
    /// gets the same bits alone or among others.
    ///
    /// # Panics
    /// If `out.len() != points.len()`.
    pub fn displacement_normal_f32(&self, points: &[DVec2], out: &mut [SurfacePointF32]) {
        assert_eq!(points.len(), out.len(), "one output per point");
        for_blocks(
            points,
            out,
            #[inline(always)]
            |block, dst| {
                let lanes = self.lanes_f32(block, true);
                let n = lanes.normals();
                for (l, o) in dst.iter_mut().enumerate() {
                    *o = SurfacePointF32 {
                        displacement: Vec3::new(
                            lanes.disp[0][l],
                            lanes.disp[1][l],
                            lanes.disp[2][l],
                        ),
                        normal: Vec3::new(n[0][l], n[1][l], n[2][l]),
                    };
                }
            },
        );
    }

    /// Slow reference for [`SurfaceAt::sample`]: analytic waves with unreduced phases and the
    /// platform's f64 sin/cos, FFT layers by direct Fourier summation at the exact point,
    /// particle layers from their closed forms without grids
    /// ([`ParticleField::sample_reference`]).
    /// Always computes derivatives. For tests and the accuracy report only.
    pub fn sample_reference(&self, p0: DVec2) -> SurfaceSample {
        let mut out = SurfaceSample::default();
        for (i, layer) in self.surface.layers.iter().enumerate() {
            match layer {
                Layer::Sine(_) | Layer::Gerstner(_) => {
                    for w in layer.waves() {
                        w.accumulate_reference(p0, self.t, &mut out);
                    }
                }
                Layer::Particles(p) => {
                    if let Some(field) = self.particle_field(i) {
                        let (h, g, _) = field.sample_reference(p, p0);
                        out.displacement.y += h;
                        out.d_dx.y += g.x;
                        out.d_dz.y += g.y;
                    }
                }
                Layer::Fft(f) => {
                    let s = f.sample_reference(p0, self.t);
                    out.displacement += s.displacement;
                    out.d_dx += DVec3::new(s.jacobian.x, s.slope.x, s.jacobian.z);
                    out.d_dz += DVec3::new(s.jacobian.z, s.slope.y, s.jacobian.y);
                }
            }
        }
        out
    }
}

/// Adds an FFT layer's fields to lane `l`: displacement always, derivatives only if asked
/// (exactly the additions the one-point path has always made). jacobian = (∂Dx/∂x, ∂Dz/∂z,
/// ∂Dx/∂z) and ∂Dz/∂x = ∂Dx/∂z (the displacement is irrotational).
#[inline]
fn add_fft<const B: usize>(
    out: &mut Lanes<B>,
    l: usize,
    s: &crate::fft::FftSample,
    derivatives: bool,
) {
    if derivatives {
        out.add(
            l,
            &SurfaceSample {
                displacement: s.displacement,
                d_dx: DVec3::new(s.jacobian.x, s.slope.x, s.jacobian.z),
                d_dz: DVec3::new(s.jacobian.z, s.slope.y, s.jacobian.y),
            },
        );
    } else {
        out.add_displacement(l, s.displacement);
    }
}

/// Runs `f` over `points` in blocks of [`crate::wave::BLOCK`], with the matching slice of `out`.
/// The last, partial block is padded by repeating its last point; padded lanes are computed and
/// dropped (lanes never interact, so padding cannot change a result).
///
/// On x86-64 CPUs with AVX2 or AVX-512 F the loop (and everything `f` inlines) is compiled for
/// that level and chosen at run time ([`crate::simd::simd_level`]), whatever level the crate was
/// built for: two or four times the lanes per instruction, the same bits. The kernels are plain
/// `*`, `+`, `−`, `/` and `sqrt` in a fixed order (no fused multiply-add: only `avx2` or
/// `avx512f` is enabled, never `fma`, and Rust never contracts `a * b + c`), so each operation
/// rounds exactly as in the baseline build; `tests/simd_levels.rs` compares every level bit for
/// bit.
#[inline]
pub(crate) fn for_blocks<T>(
    points: &[DVec2],
    out: &mut [T],
    f: impl FnMut(&[DVec2; BLOCK], &mut [T]),
) {
    #[cfg(target_arch = "x86_64")]
    match crate::simd::simd_level() {
        crate::simd::SimdLevel::Avx512 => {
            // SAFETY: `simd_level` is Avx512 only where the CPU has AVX-512 F (detected at run
            // time).
            unsafe { blocks_avx512(points, out, f) };
            return;
        }
        crate::simd::SimdLevel::Avx2 => {
            // SAFETY: `simd_level` is Avx2 only where the CPU has AVX2 (detected at run time).
            unsafe { blocks_avx2(points, out, f) };
            return;
        }
        _ => {}
    }
    blocks(points, out, f);
}

const BLOCK: usize = crate::wave::BLOCK;

#[inline(always)]
fn blocks<T>(points: &[DVec2], out: &mut [T], mut f: impl FnMut(&[DVec2; BLOCK], &mut [T])) {
    for (src, dst) in points.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
        let block: [DVec2; BLOCK] = std::array::from_fn(|l| src[l.min(src.len() - 1)]);
        f(&block, dst);
    }
}

/// [`blocks`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn blocks_avx2<T>(points: &[DVec2], out: &mut [T], f: impl FnMut(&[DVec2; BLOCK], &mut [T])) {
    blocks(points, out, f);
}

/// [`blocks`] compiled for AVX-512 F: a block's 8 f64 lanes are one register (never FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn blocks_avx512<T>(points: &[DVec2], out: &mut [T], f: impl FnMut(&[DVec2; BLOCK], &mut [T])) {
    blocks(points, out, f);
}

/// Whether batch loops may take the run-time AVX2 path (on by default; tests turn it off to
/// compare the two paths bit for bit).
static SIMD: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

#[inline]
pub(crate) fn simd_enabled() -> bool {
    SIMD.load(std::sync::atomic::Ordering::Relaxed)
}

/// Turns the run-time selected AVX2 batch loops on or off (process-wide; on by default). Results
/// are the same either way; this exists so that tests and benchmarks can compare the two.
#[doc(hidden)]
pub fn set_simd_dispatch(on: bool) {
    SIMD.store(on, std::sync::atomic::Ordering::Relaxed);
}
