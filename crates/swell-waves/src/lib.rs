//! # swell-waves
//!
//! Swell's wave model: one deterministic sea, keyed by time and world position, that every game
//! client and server evaluates to the same bits. A plain library: no I/O, no async, no clock.
//!
//! ```
//! use swell_waves::{Surface, SurfaceSpec, LayerSpec, QueryFields, QueryOptions};
//! use swell_waves::gerstner::{GerstnerLayerSpec, GerstnerWave};
//!
//! let spec = SurfaceSpec {
//!     seed: 1,
//!     gravity: 9.81,
//!     depth: None,
//!     layers: vec![LayerSpec::Gerstner(GerstnerLayerSpec {
//!         waves: vec![GerstnerWave {
//!             amplitude: 0.5, wavelength: 20.0, direction: [1.0, 0.0],
//!             phase: 0.0, speed: None, steepness: 0.8,
//!         }],
//!         ..Default::default()
//!     })],
//! };
//! let surface = Surface::new(&spec).unwrap();
//! let sea = surface.at(12.5, QueryFields::ALL, &QueryOptions::default()).unwrap();
//! let p = sea.query(glam::DVec2::new(3.0, -4.0), QueryFields::ALL);
//! assert!(p.residual <= 1e-5 && p.height.abs() <= 0.5);
//! ```
//!
//! # Layout
//! - [`math`] — phase reduction, deterministic sin/cos, the specified seeded generator.
//! - [`spectrum`] — dispersion relation; Phillips, Pierson–Moskowitz, JONSWAP and TMA spectra;
//!   directional spreading.
//! - [`wave`] — one travelling wave and the summed [`wave::SurfaceSample`] (displacement and
//!   derivatives) every layer produces.
//! - [`sine`] — compound sine layers.
//! - [`gerstner`] — Gerstner layers: explicit waves, cascades, fold number.
//! - [`fft`] — the Tessendorf FFT ocean: seeded h0(k), time evolution, inverse transforms,
//!   grid sampling, and the direct-summation reference.
//! - [`surface`] — [`Surface`] (the layers a scene declares) and [`SurfaceAt`] (frozen at `t`).
//! - [`query`] — height with inversion, normal, displacement, Jacobian/fold, residual; batches.
//! - [`body`] — floating bodies: orientation from probe points, and the deterministic rigid-body
//!   buoyancy simulation ([`body::World`]).
//! - [`particles`] — wave particles: seeded ambient particles on a periodic tile and impact
//!   ripples (rings that expand, subdivide and fade), both in closed form in t.
//! - [`velocity`] — orbital velocity of the water at the surface (∂/∂t of the displacement).
//! - [`error`] — [`SpecError`], the typed validation error.
//! - [`simd`] — the run-time SIMD level of the batch kernels and FFT, and `SWELL_SIMD`.
//!
//! # Conventions
//! - Right-handed, **y up**, the sea surface lies in x/z. Metres, seconds, radians, kilograms.
//!   Gravity defaults to 9.81 m/s².
//! - Wave number `k = 2π/λ`. Dispersion `ω = sqrt(g·k)` in deep water and
//!   `ω = sqrt(g·k·tanh(k·h))` at depth h; a wave may give its phase speed c instead (`ω = c·k`).
//! - Directions are `[x, z]` vectors, normalised on input; a zero vector is an error.
//! - Compound sine: `y = Σ A·sin(k·(d·p) − ω·t + φ)`, no horizontal motion.
//! - Gerstner: a point p0 of the flat sea moves to `x = p0 + Σ Q·A·d·cos θ`, `y = Σ A·sin θ`,
//!   `θ = k·(d·p0) − ω·t + φ`, steepness Q in [0, 1]. The fold number `S = Σ Q·k·A` must be < 1.
//! - FFT: `h(x, t) = Σ_k h̃(k, t)·e^{i k·x}`, `h̃ = h0(k)·e^{−iωt} + conj(h0(−k))·e^{iωt}` (so
//!   each component travels along +k, like Gerstner), horizontal displacement
//!   `D = Σ i·λ·(k/|k|)·h̃·e^{i k·x}` (Gerstner-like sharp crests). The inverse transforms are
//!   unnormalised sums (no 1/N²): h0 carries the physical amplitude.
//! - Wave particles: a particle of amplitude a and radius r at c adds `a·(1 − |x − c|²/r²)³`
//!   (zero beyond r) to the elevation only; ambient particles sit at `wrap(p0 + v·t)` on a
//!   periodic tile, impact rings follow closed forms in t ([`particles`]).
//! - "Height at (x, z)" is the elevation of the surface point that lies above world (x, z) after
//!   horizontal displacement: the model solves `p0 + D(p0, t) = (x, z)`. Displacement at the
//!   undisplaced point is the separate [`SurfaceAt::displacement`].
//! - World positions are f64. Every phase is formed in f64 and reduced to [−π, π] before
//!   anything else is done with it.
//!
//! # Determinism
//! Same spec + same time + same point = same bits, on every run, at every batch size and thread
//! count, on x86-64 and aarch64:
//! - sin/cos come from a fixed polynomial kernel in [`math`]; exp/ln/pow/tanh from the pure-Rust
//!   `libm` crate; no `mul_add`, no fast-math, no platform maths in results;
//! - each point is evaluated on its own (no reductions across points), so a batch answer equals
//!   the single answer and threads only split the work; batches run blocks of
//!   [`wave::BLOCK`] points through branch-free, vectorisable kernels, and a single point is a
//!   block of one, so both run the same code and the same arithmetic at every x86-64 level;
//! - random numbers come from the generator specified in [`math`] (PCG32 keyed by splitmix64),
//!   pinned by tests; FFT draws are keyed by wave vector, not by grid size;
//! - FFT frames use the crate's own FFT by default ([`fft::FftBackend::Portable`]): RustFFT's
//!   scalar plan ported operation for operation, so its bits are the ones RustFFT's scalar
//!   planner gave (tested), run on 1, 2, 4 or 8 transforms at once; the `Native` backend
//!   (RustFFT's SIMD planner) has low bits that depend on the CPU's SIMD support;
//! - batch loops and FFT frames pick an SSE2, AVX2 or AVX-512 compiled copy at run time
//!   ([`simd::simd_level`]; `SWELL_SIMD` forces one): "vertical" SIMD, each lane doing the
//!   scalar operation sequence, never `fma`, so every level gives the scalar bits
//!   (`tests/simd_levels.rs`, run under each level in CI).
//!
//! # Precision
//! [`QueryOptions::precision`] picks the arithmetic: [`Precision::F64`] (the default, the model
//! above) or [`Precision::F32`], the single-precision fast path for rendering and probes (phases
//! reduced in f64 in turns, then f32 sin/cos, sums and normals; a few micrometres off f64 for
//! several times less work; [`SurfaceAt::displacement_normal_f32`]). `F32` is just as
//! deterministic, with its own golden vectors, but it is a different model: replicas that must
//! agree use the same precision.
//!
//! Golden vectors in `proto/vectors/` pin the outputs; changing them is a model-version change
//! ([`MODEL_VERSION`]).
#![warn(missing_docs)]

pub mod body;
pub mod error;
pub mod fft;
pub mod gerstner;
pub mod math;
pub mod particles;
pub mod query;
pub mod simd;
pub mod sine;
pub mod spectrum;
pub mod surface;
pub mod velocity;
pub mod wave;

pub use error::SpecError;
pub use query::{
    Inversion, InversionMethod, PointResult, Precision, QueryFields, QueryOptions, TimeSampling,
};
pub use surface::{
    FrameMemo, Layer, LayerFrames, LayerSpec, Surface, SurfaceAt, SurfacePointF32, SurfaceSpec,
};

/// Version of the model's numbers. Bumped whenever the golden vectors in `proto/vectors/` have to
/// be re-minted: clients compare it to know they render the same sea as the server.
///
/// - 1: the first published model.
/// - 2: FFT layers are read from their time grid by default (frames at `n·Δ`, Δ = 1/60 s,
///   linear in between; [`TimeSampling`]), so FFT answers between grid times moved by up to a
///   few tenths of a millimetre. `accuracy.time = "exact"` gives version 1's FFT numbers.
/// - 3: Newton's steps take an FFT layer's horizontal Jacobian from the derivatives of the
///   Catmull–Rom interpolant of its displacement grids ([`fft::FftFrame::newton_jacobian`]),
///   not from three more transformed grids: a frame for heights costs 3 transforms instead of
///   6. The root solved for is the same; heights on choppy FFT seas moved in their last bits
///   (under a micrometre: 0.8 µm at most in the golden vectors), and so did bodies on them. Sine, Gerstner and particle answers
///   did not change.
pub const MODEL_VERSION: u32 = 3;
