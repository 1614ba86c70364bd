//! Point queries on a [`SurfaceAt`]: height at a world point (inverting the horizontal
//! displacement), normal, displacement at an undisplaced point, Jacobian and fold flag, and the
//! inversion residual; single points and batches, bit-identical either way.
//!
//! "Height at (x, z)" is the elevation of the surface point that lies above world (x, z) after
//! horizontal displacement: we solve `p0 + D(p0, t) = (x, z)` for `p0` and return `y(p0, t)`.

use glam::{DVec2, DVec3};

use crate::error::{SpecError, finite};
use crate::fft::{FftReads, SampleFilter};
use crate::surface::SurfaceAt;
use crate::wave::SurfaceSample;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Most inversion iterations a query may ask for.
pub const MAX_ITERATIONS: u32 = 64;

/// How to solve `p0 + D(p0) = target`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum InversionMethod {
    /// `p0 ← target − D(p0)`: one evaluation per step, no derivatives; converges linearly with
    /// rate up to the fold number S, so slowly for steep seas.
    FixedPoint,
    /// Newton on `F(p0) = p0 + D(p0) − target` with the 2×2 Jacobian of D (sine and Gerstner
    /// layers' analytic one; an FFT layer's the derivative of the interpolant of its
    /// displacement grids, [`crate::fft::FftFrame::newton_jacobian`]): quadratic convergence;
    /// falls back to a fixed-point step where the Jacobian is singular. The default.
    #[default]
    Newton,
}

/// Inversion settings: method, iteration cap and tolerance.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct Inversion {
    /// Method. Default Newton.
    pub method: InversionMethod,
    /// Most update steps, 0..=64. Default 8: Newton reaches 0.01 mm in 3–5 steps up to
    /// S = 0.9 and stays under 1 mm at S = 0.99.
    pub iterations: u32,
    /// Stop once the residual `|p0 + D(p0) − target|` is at most this, m (≥ 0). Default
    /// 1e-5 m (0.01 mm), far below anything a renderer can show.
    pub tolerance: f64,
}

impl Default for Inversion {
    fn default() -> Self {
        Self {
            method: InversionMethod::Newton,
            iterations: 8,
            tolerance: 1e-5,
        }
    }
}

/// Everything a query may be asked to compute. Fields not asked are not computed (and read 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct QueryFields {
    /// Height at the world point (with inversion).
    pub height: bool,
    /// Unit normal of the displaced surface at the world point.
    pub normal: bool,
    /// Displacement `(Dx, y, Dz)` at the world point taken as an undisplaced point.
    pub displacement: bool,
    /// Jacobian determinant and fold flag at the world point.
    pub jacobian: bool,
    /// Inversion residual.
    pub residual: bool,
}

impl QueryFields {
    /// Height only.
    pub const HEIGHT: QueryFields = QueryFields {
        height: true,
        normal: false,
        displacement: false,
        jacobian: false,
        residual: false,
    };
    /// Every field.
    pub const ALL: QueryFields = QueryFields {
        height: true,
        normal: true,
        displacement: true,
        jacobian: true,
        residual: true,
    };
}

/// Query settings: inversion and FFT grid sampling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QueryOptions {
    /// Height inversion settings.
    pub inversion: Inversion,
    /// How FFT grids are sampled between nodes. Default bicubic.
    pub filter: SampleFilter,
    /// Evaluate FFT layers by direct f64 Fourier summation at the exact point instead of the
    /// grid (slow; the reference for tests and the accuracy report).
    pub reference: bool,
    /// Arithmetic of the surface evaluation behind every query. Default [`Precision::F64`], the
    /// model's bits (the golden vectors pin it).
    pub precision: Precision,
    /// How FFT layers are read at the query time. Default [`TimeSampling::Grid`].
    pub time: TimeSampling,
}

/// How an FFT layer is read at a query time t.
///
/// Both are deterministic and part of the model; they differ by at most
/// `max|∂²h/∂t²|·Δ²/8` (under 1 mm on the built-in seas at the default Δ = 1/60 s, see
/// `docs/accuracy.md`). Analytic layers are always evaluated at t itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum TimeSampling {
    /// Linear interpolation between the frames at the grid times around t
    /// ([`crate::fft::FftLayer::grid_position`]): at most two frames for any t, shared by every
    /// query between the same grid times, so a server can cache them. The default.
    #[default]
    Grid,
    /// A frame computed at t itself: one FFT per distinct t (slow for many distinct times).
    Exact,
}

/// Arithmetic precision of a surface evaluation.
///
/// Both are deterministic: the same inputs give the same bits on every CPU and at every
/// x86-64 level, single point or batch. They are different models, though: an `F32` answer is
/// close to, not equal to, the `F64` one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// f64 throughout: the model's reference results (about 10⁻¹⁵ relative).
    #[default]
    F64,
    /// The single-precision fast path: each analytic wave's phase is formed and reduced in f64,
    /// then sin/cos, products and sums run in f32 lanes
    /// ([`crate::wave::WaveSoA::accumulate_lanes_f32`]); FFT layers are read from their f64
    /// grids and join the f32 sum. Errors of about 10⁻⁶ of the wave amplitudes (measured in
    /// `docs/accuracy.md`), for several times less work.
    F32,
}

impl Default for QueryOptions {
    fn default() -> Self {
        Self {
            inversion: Inversion::default(),
            filter: SampleFilter::Bicubic,
            reference: false,
            precision: Precision::F64,
            time: TimeSampling::Grid,
        }
    }
}

impl QueryOptions {
    /// Checks the settings.
    ///
    /// # Errors
    /// `inversion.iterations` above [`MAX_ITERATIONS`]; a negative or non-finite tolerance.
    pub fn validate(&self) -> Result<(), SpecError> {
        if self.inversion.iterations > MAX_ITERATIONS {
            return Err(SpecError::OutOfRange {
                field: "accuracy.iterations".into(),
                value: self.inversion.iterations as f64,
                allowed: format!("in [0, {MAX_ITERATIONS}]"),
            });
        }
        finite("accuracy.tolerance", self.inversion.tolerance)?;
        if self.inversion.tolerance < 0.0 {
            return Err(SpecError::OutOfRange {
                field: "accuracy.tolerance".into(),
                value: self.inversion.tolerance,
                allowed: ">= 0 m".into(),
            });
        }
        Ok(())
    }
}

/// The result of inverting the horizontal displacement at one world point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inverted {
    /// The undisplaced point p0 found, m.
    pub source: DVec2,
    /// The surface sample at `source` (derivatives present if they were needed).
    pub sample: SurfaceSample,
    /// `|source + D(source) − target|`, m.
    pub residual: f64,
    /// Update steps taken.
    pub iterations: u32,
}

/// All answers for one world point; fields not asked are 0 (`normal` is straight up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointResult {
    /// Elevation of the surface above the world point, m.
    pub height: f64,
    /// Unit normal of the displaced surface there.
    pub normal: DVec3,
    /// `(Dx, y, Dz)` at the world point taken as undisplaced, m.
    pub displacement: DVec3,
    /// Jacobian determinant of the horizontal map at the source point.
    pub jacobian: f64,
    /// `jacobian ≤ 0`: the surface folds here (foam, and the height is ambiguous).
    pub folded: bool,
    /// Inversion residual, m.
    pub residual: f64,
}

impl Default for PointResult {
    fn default() -> Self {
        Self {
            height: 0.0,
            normal: DVec3::Y,
            displacement: DVec3::ZERO,
            jacobian: 1.0,
            folded: false,
            residual: 0.0,
        }
    }
}

impl SurfaceAt<'_> {
    /// Displacement `(Dx, y, Dz)` of the undisplaced point `p0`, m.
    pub fn displacement(&self, p0: DVec2) -> DVec3 {
        self.sample(p0, false).displacement
    }

    /// Solves `p0 + D(p0) = target` with the snapshot's inversion settings. Returns the best
    /// iterate seen (lowest residual), so more iterations never make the answer worse.
    /// `derivatives` asks for the derivatives at the returned point (for normals/Jacobians);
    /// without it the returned sample's derivatives are not meant to be read (Newton's
    /// rounds compute the horizontal ones, and leave FFT layers' slopes out).
    ///
    /// This is [`SurfaceAt::invert_lanes`] with a block of one point.
    pub fn invert(&self, target: DVec2, derivatives: bool) -> Inverted {
        self.invert_lanes(&[target], derivatives)[0]
    }

    /// [`SurfaceAt::invert`] for `B` targets at once. Each lane runs its own iteration (its own
    /// step count and stopping test); every round evaluates the whole block with
    /// [`SurfaceAt::sample_lanes`] and lanes that have stopped ignore the result. Lane `l` is
    /// bit-identical to `invert(targets[l])`.
    #[inline(always)]
    pub fn invert_lanes<const B: usize>(
        &self,
        targets: &[DVec2; B],
        derivatives: bool,
    ) -> [Inverted; B] {
        self.invert_lanes_v::<B, false>(targets, targets, derivatives, &mut [[0.0; B]; 3])
    }

    /// [`SurfaceAt::invert_lanes`]; with `V` it also leaves in `velocity` the analytic layers'
    /// particle velocities at each lane's returned source point, taken from the `sin_cos` of
    /// the round that found it ([`SurfaceAt::sample_lanes_f64`]). With `V` the f64 kernel runs
    /// whatever the snapshot's precision (there is no f32 velocity kernel): callers ask for it
    /// on [`crate::Precision::F64`] snapshots only. The iteration starts from `starts` (the
    /// targets themselves for [`SurfaceAt::invert_lanes`]).
    #[inline(always)]
    pub(crate) fn invert_lanes_v<const B: usize, const V: bool>(
        &self,
        targets: &[DVec2; B],
        starts: &[DVec2; B],
        derivatives: bool,
        velocity: &mut [[f64; B]; 3],
    ) -> [Inverted; B] {
        let inv = self.options.inversion;
        let newton = inv.method == InversionMethod::Newton;
        let fft = self.surface.has_fft();
        // What a round reads: the displacement, and for Newton's step the horizontal Jacobian
        // (an FFT layer's from the interpolant of its displacement grids, `FftReads::Newton`).
        // A caller that wants derivatives gets them from one more evaluation at the point kept
        // when the surface has an FFT layer (its Jacobian and slope grids); without one, the
        // rounds compute them (the analytic layers' derivatives are the same either way).
        let rounds = if newton {
            FftReads::Newton
        } else if derivatives && !fft {
            FftReads::All
        } else {
            FftReads::Displacement
        };
        if !self.surface.has_horizontal_motion() {
            let s = self.round_lanes::<B, V>(
                targets,
                FftReads::every(derivatives),
                &[true; B],
                velocity,
                true,
            );
            return std::array::from_fn(|l| Inverted {
                source: targets[l],
                sample: s.get(l),
                residual: 0.0,
                iterations: 0,
            });
        }
        let mut p = *starts;
        let mut best = [Inverted {
            source: DVec2::ZERO,
            sample: SurfaceSample::default(),
            residual: f64::INFINITY,
            iterations: 0,
        }; B];
        let mut seen = [false; B];
        let mut active = [true; B];
        let mut it = 0;
        // Particle layers move the surface vertically only: the rounds, which steer by the
        // horizontal displacement, leave them out, and one last evaluation at the points kept
        // adds them (the same function at the same point, so the same bits as evaluating them
        // every round, at a fraction of the cost).
        let later = self.surface.has_particles();
        while active.iter().any(|&a| a) {
            let mut round = [[0.0; B]; 3];
            // Lanes that have converged keep their best round: only the others read the FFT
            // frames again (the analytic kernel does all lanes at once either way).
            let lanes = self.round_lanes::<B, V>(&p, rounds, &active, &mut round, !later);
            for l in 0..B {
                if !active[l] {
                    continue;
                }
                let s = lanes.get(l);
                let target = targets[l];
                let f = p[l] + DVec2::new(s.displacement.x, s.displacement.z) - target;
                let r = f.length();
                if !seen[l] || r < best[l].residual {
                    seen[l] = true;
                    best[l] = Inverted {
                        source: p[l],
                        sample: s,
                        residual: r,
                        iterations: it,
                    };
                    if V {
                        for (v, r) in velocity.iter_mut().zip(&round) {
                            v[l] = r[l];
                        }
                    }
                }
                if r <= inv.tolerance || it >= inv.iterations || !r.is_finite() {
                    active[l] = false;
                    continue;
                }
                let step = inversion_step(&s, f, newton);
                p[l] -= step;
            }
            it += 1;
        }
        if later || (derivatives && fft) {
            let kept: [DVec2; B] = std::array::from_fn(|l| best[l].source);
            let mut round = [[0.0; B]; 3];
            let reads = if derivatives { FftReads::All } else { rounds };
            let full = self.round_lanes::<B, V>(&kept, reads, &[true; B], &mut round, true);
            for (l, b) in best.iter_mut().enumerate() {
                b.sample = full.get(l);
            }
            if V {
                *velocity = round;
            }
        }
        best
    }

    /// One round of [`SurfaceAt::invert_lanes_v`]: the block sampled at the snapshot's
    /// precision (always f64 with `V`), reading the FFT grids `reads` names, for the lanes
    /// `wanted` marks (in f64; the f32 path reads every lane).
    #[inline(always)]
    fn round_lanes<const B: usize, const V: bool>(
        &self,
        p: &[DVec2; B],
        reads: FftReads,
        wanted: &[bool; B],
        velocity: &mut [[f64; B]; 3],
        particles: bool,
    ) -> crate::wave::Lanes<B> {
        if V || self.options.precision == crate::Precision::F64 {
            self.sample_lanes_f64::<B, V>(p, reads, wanted, velocity, particles)
        } else {
            self.lanes_f32_with(p, reads, particles).widen()
        }
    }

    /// Slow reference inversion: Newton on [`SurfaceAt::sample_reference`] for up to 200 steps,
    /// halving any step that does not reduce the residual, until the residual is below 1e-11 m.
    /// For tests and the accuracy report.
    pub fn invert_reference(&self, target: DVec2) -> Inverted {
        let mut p = target;
        let mut s = self.sample_reference(p);
        let resid = |p: DVec2, s: &SurfaceSample| {
            p + DVec2::new(s.displacement.x, s.displacement.z) - target
        };
        let mut f = resid(p, &s);
        let mut it = 0;
        while f.length() > 1e-11 && it < 200 {
            let (a, b) = (1.0 + s.d_dx.x, s.d_dz.x);
            let (c, d) = (s.d_dx.z, 1.0 + s.d_dz.z);
            let det = a * d - b * c;
            let mut step = if det.abs() > 1e-14 {
                DVec2::new((d * f.x - b * f.y) / det, (a * f.y - c * f.x) / det)
            } else {
                f
            };
            let mut accepted = false;
            for _ in 0..40 {
                let q = p - step;
                let sq = self.sample_reference(q);
                let fq = resid(q, &sq);
                if fq.length() < f.length() {
                    (p, s, f) = (q, sq, fq);
                    accepted = true;
                    break;
                }
                step *= 0.5;
            }
            it += 1;
            if !accepted {
                break;
            }
        }
        Inverted {
            source: p,
            sample: s,
            residual: f.length(),
            iterations: it,
        }
    }

    /// Height of the surface above world `(x, z)`, m.
    pub fn height(&self, x: f64, z: f64) -> f64 {
        self.invert(DVec2::new(x, z), false).sample.displacement.y
    }

    /// Answers `fields` at the world point `world` ([`SurfaceAt::query_lanes`] with one point).
    pub fn query(&self, world: DVec2, fields: QueryFields) -> PointResult {
        self.query_lanes(&[world], fields)[0]
    }

    /// Answers `fields` at `B` world points at once; lane `l` is bit-identical to
    /// `query(worlds[l])`.
    #[inline(always)]
    pub fn query_lanes<const B: usize>(
        &self,
        worlds: &[DVec2; B],
        fields: QueryFields,
    ) -> [PointResult; B] {
        let mut out = [PointResult::default(); B];
        if fields.height || fields.normal || fields.jacobian || fields.residual {
            let derivs = fields.normal || fields.jacobian;
            let inv = self.invert_lanes(worlds, derivs);
            for (o, inv) in out.iter_mut().zip(&inv) {
                if fields.height {
                    o.height = inv.sample.displacement.y;
                }
                if fields.normal {
                    o.normal = inv.sample.normal();
                }
                if fields.jacobian {
                    o.jacobian = inv.sample.jacobian();
                    o.folded = o.jacobian <= 0.0;
                }
                if fields.residual {
                    o.residual = inv.residual;
                }
            }
        }
        if fields.displacement {
            let d = self.sample_lanes(worlds, false);
            for (l, o) in out.iter_mut().enumerate() {
                o.displacement = d.get(l).displacement;
            }
        }
        out
    }

    /// Answers `fields` for every point, in order, in blocks of [`crate::wave::BLOCK`] points.
    /// Bit-identical to calling [`SurfaceAt::query`] point by point.
    pub fn query_batch(&self, points: &[DVec2], fields: QueryFields) -> Vec<PointResult> {
        let mut out = vec![PointResult::default(); points.len()];
        self.query_batch_into(points, fields, &mut out);
        out
    }

    /// [`SurfaceAt::query_batch`] into a caller's buffer (no allocation).
    ///
    /// # Panics
    /// If `out.len() != points.len()`.
    pub fn query_batch_into(&self, points: &[DVec2], fields: QueryFields, out: &mut [PointResult]) {
        assert_eq!(points.len(), out.len(), "one output per point");
        crate::surface::for_blocks(
            points,
            out,
            #[inline(always)]
            |block, dst| {
                let r = self.query_lanes(block, fields);
                dst.copy_from_slice(&r[..dst.len()]);
            },
        );
    }

    /// Like [`SurfaceAt::query_batch`], split over `threads` OS threads (scoped). Each point is
    /// computed exactly as alone, so the result is bit-identical for any thread count.
    pub fn query_batch_parallel(
        &self,
        points: &[DVec2],
        fields: QueryFields,
        threads: usize,
    ) -> Vec<PointResult> {
        let threads = threads.clamp(1, 64);
        if threads == 1 || points.len() < 2 {
            return self.query_batch(points, fields);
        }
        let chunk = points.len().div_ceil(threads);
        let mut out = vec![PointResult::default(); points.len()];
        std::thread::scope(|scope| {
            for (src, dst) in points.chunks(chunk).zip(out.chunks_mut(chunk)) {
                scope.spawn(move || self.query_batch_into(src, fields, dst));
            }
        });
        out
    }
}

/// One update of the inversion of `p0 + D(p0) = target`, given the sample `s` at the current
/// iterate and its residual `f = p0 + D(p0) − target`: the Newton step `J⁻¹·f` with
/// `J = ∂F/∂p0 = [[1 + ∂Dx/∂x, ∂Dx/∂z], [∂Dz/∂x, 1 + ∂Dz/∂z]]`, or the fixed-point step `f`
/// (also Newton's fallback where `det J ≤ 1e-9`, i.e. at or near a fold). The iterate moves to
/// `p0 − step`.
#[inline]
pub(crate) fn inversion_step(s: &SurfaceSample, f: DVec2, newton: bool) -> DVec2 {
    inversion_step_slopes([s.d_dx.x, s.d_dz.x, s.d_dx.z, s.d_dz.z], f, newton)
}

/// [`inversion_step`] from the four horizontal displacement slopes alone,
/// `[∂Dx/∂x, ∂Dx/∂z, ∂Dz/∂x, ∂Dz/∂z]` (all it reads of the sample).
#[inline]
pub(crate) fn inversion_step_slopes(slopes: [f64; 4], f: DVec2, newton: bool) -> DVec2 {
    if !newton {
        return f;
    }
    let (a, b) = (1.0 + slopes[0], slopes[1]);
    let (c, d) = (slopes[2], 1.0 + slopes[3]);
    let det = a * d - b * c;
    if det > 1e-9 {
        DVec2::new((d * f.x - b * f.y) / det, (a * f.y - c * f.x) / det)
    } else {
        f
    }
}
